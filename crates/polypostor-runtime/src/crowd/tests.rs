use super::*;
use crate::gpu::{Camera, Projection};
use crate::viewpoints::{Coverage, directions};
use lod::LodDistances;

fn camera(eye: Vec3, target: Vec3, w: f32, h: f32) -> CrowdCamera {
    let fov = 50f32.to_radians();
    let cam = Camera {
        eye,
        target,
        up: Vec3::Y,
        projection: Projection::Perspective { fov_y_rad: fov },
        near: 0.1,
        far: 2000.0,
    };
    CrowdCamera {
        eye,
        clip_from_world: cam.clip_from_world(w / h),
        focal_px: h / (2.0 * (fov / 2.0).tan()),
    }
}

/// Brute force over all pairs.
fn closest_pair(pos: &[Vec2]) -> f32 {
    let mut best = f32::INFINITY;
    for i in 0..pos.len() {
        for j in i + 1..pos.len() {
            best = best.min(pos[i].distance(pos[j]));
        }
    }
    best
}

#[test]
fn agents_never_come_closer_than_the_minimum_distance_and_stay_on_the_ground() {
    let params = CrowdParams {
        count: 600,
        density: 1.0, // crowded, so they bump into each other often
        seed: 11,
        ..Default::default()
    };
    let mut crowd = Crowd::new(params.clone());
    assert_eq!(crowd.len(), 600);
    let start = crowd.agents.pos.clone();
    for step in 0..300 {
        crowd.simulate(1.0 / 30.0);
        if step % 50 == 0 || step == 299 {
            let d = closest_pair(&crowd.agents.pos);
            assert!(d >= params.min_distance * (1.0 - 1e-5), "step {step}: {d}");
        }
    }
    assert!(
        crowd
            .agents
            .pos
            .iter()
            .all(|p| p.x.abs() < crowd.half_extent && p.y.abs() < crowd.half_extent)
    );
    // They do walk: most moved well away from where they started.
    let moved = start
        .iter()
        .zip(&crowd.agents.pos)
        .filter(|(a, b)| a.distance(**b) > 1.0)
        .count();
    assert!(moved > 400, "{moved} of 600 moved more than 1 m in 10 s");
}

#[test]
fn the_same_seed_gives_the_same_crowd_and_pause_stops_it() {
    let run = |seed| {
        let mut c = Crowd::new(CrowdParams {
            count: 300,
            seed,
            ..Default::default()
        });
        for _ in 0..50 {
            c.simulate(0.05);
        }
        c
    };
    let (a, b, c) = (run(5), run(5), run(6));
    assert_eq!(a.agents.pos, b.agents.pos);
    assert_ne!(a.agents.pos, c.agents.pos);
    let mut p = run(5);
    p.set_paused(true);
    let before = p.agents.pos.clone();
    p.simulate(0.05);
    assert_eq!(before, p.agents.pos);
}

#[test]
fn culling_keeps_what_the_camera_sees_and_drops_what_is_behind_it() {
    let mut crowd = Crowd::new(CrowdParams {
        count: 2000,
        seed: 3,
        ..Default::default()
    });
    // Looking along +Z from the middle of one side.
    let cam = camera(Vec3::new(0.0, 1.7, 0.0), Vec3::new(0.0, 1.7, 10.0), 1600.0, 900.0);
    let views = ViewLookup::new(&directions(137, Coverage::UpperHemisphere));
    let clip = ClipTiming { frames: 10, fps: 10.0 };
    let stats = crowd.select(&cam, &LodPolicy::Only(Level::Polypostor), &views, clip);
    assert!(stats.visible > 0);
    let kept: Vec<Vec2> = crowd.instances[0][Level::Polypostor as usize]
        .iter()
        .map(|i| Vec2::new(i.pos[0], i.pos[1]))
        .collect();
    // Independent check: project every agent's feet and head; anything whose both project
    // well inside the image must be kept, anything behind the camera must not be.
    for p in &crowd.agents.pos {
        let inside = |y: f32| {
            let c = cam.clip_from_world * Vec3::new(p.x, y, p.y).extend(1.0);
            c.w > 0.2 && (c.x / c.w).abs() < 0.9 && (c.y / c.w).abs() < 0.9 && c.z / c.w < 1.0
        };
        let is_kept = kept.contains(p);
        if inside(0.0) && inside(1.8) {
            assert!(is_kept, "{p} in view but culled");
        }
        if p.y < -1.5 {
            assert!(!is_kept, "{p} behind the camera but kept");
        }
    }
    assert_eq!(stats.per_level.iter().sum::<usize>(), stats.visible);
}

#[test]
fn the_view_is_the_camera_direction_in_the_character_frame() {
    let views = directions(137, Coverage::UpperHemisphere);
    let lookup = ViewLookup::new(&views);
    let mut crowd = Crowd::new(CrowdParams {
        count: 1,
        ..Default::default()
    });
    let p = crowd.agents.pos[0];
    for heading in [0.0f32, 1.0, 2.5, -2.0] {
        crowd.agents.facing[0] = Vec2::new(heading.sin(), heading.cos());
        // A camera in front of the character (along its facing), a little above it: the
        // view must be near the front view (+Z in the character's frame).
        let facing = Vec3::new(heading.sin(), 0.0, heading.cos());
        let centre = Vec3::new(p.x, 0.9, p.y);
        let eye = centre + facing * 10.0 + Vec3::Y * 2.0;
        let cam = camera(eye, centre, 800.0, 600.0);
        crowd.select(
            &cam,
            &LodPolicy::Only(Level::Impostor),
            &lookup,
            ClipTiming { frames: 1, fps: 10.0 },
        );
        let inst = crowd.instances[0][Level::Impostor as usize][0];
        let want = crate::viewpoints::nearest(&views, Vec3::new(0.0, 2.0, 10.0)).unwrap();
        assert_eq!(inst.view as usize, want, "heading {heading}");
    }
}

#[test]
fn levels_follow_the_distance_and_hysteresis_stops_popping() {
    let d = LodDistances::default();
    let policy = LodPolicy::Mixed(d);
    // Far to near: impostor, polypostor, skinned — never back.
    let mut prev = Level::Impostor;
    let mut seen = Vec::new();
    for k in 0..400 {
        let pixels = 5.0 + k as f32; // 5 .. 405 px against 128 texels
        prev = policy.choose(pixels, prev);
        if seen.last() != Some(&prev) {
            seen.push(prev);
        }
    }
    assert_eq!(seen, vec![Level::Impostor, Level::Polypostor, Level::Skinned]);
    // Jitter around the mesh switch point (128 px) inside the band: no change.
    let mut level = policy.choose(150.0, Level::Polypostor);
    assert_eq!(level, Level::Skinned);
    for k in 0..100 {
        let pixels = 128.0 + if k % 2 == 0 { 6.0 } else { -6.0 };
        level = policy.choose(pixels, level);
        assert_eq!(level, Level::Skinned);
    }
    // Beyond the band it switches.
    assert_eq!(policy.choose(100.0, Level::Skinned), Level::Polypostor);
    // The switch distance matches the ratio.
    let dist = d.distance_for_ratio(1.0, 1.8, 1000.0);
    assert!((1.8f32 * 1000.0 / dist - 128.0).abs() < 1e-3);
    assert_eq!(LodPolicy::Only(Level::Rigid).choose(1e6, Level::Impostor), Level::Rigid);
}

#[test]
fn instances_carry_the_animation_frame_and_blend() {
    let mut crowd = Crowd::new(CrowdParams {
        count: 50,
        seed: 9,
        ..Default::default()
    });
    let cam = camera(Vec3::new(0.0, 60.0, -60.0), Vec3::ZERO, 800.0, 600.0);
    let lookup = ViewLookup::new(&directions(24, Coverage::UpperHemisphere));
    let clip = ClipTiming { frames: 10, fps: 10.0 };
    crowd.select(&cam, &LodPolicy::Only(Level::Polypostor), &lookup, clip);
    let list = &crowd.instances[0][Level::Polypostor as usize];
    assert_eq!(list.len(), 50, "all in view from above");
    for inst in list {
        let (f0, f1) = frame_pair_parts(inst.frame);
        assert!(f0 < 10 && (0.0..1.0).contains(&inst.blend));
        assert_eq!(f1, (f0 + 1) % 10, "the next frame round the loop");
        let i = crowd.agents.variant.iter().position(|&v| v == inst.variant).unwrap();
        let t = crowd.agents.clock[i] * 10.0;
        assert_eq!(f0, (t.floor() as i64).rem_euclid(10) as u32);
    }
    assert_eq!(std::mem::size_of::<Instance>(), 32);
}

#[test]
fn long_runs_keep_the_frame_in_range_and_the_blend_precise() {
    let mut crowd = Crowd::new(CrowdParams {
        count: 10,
        ..Default::default()
    });
    for c in &mut crowd.agents.clock {
        *c += 1.0e5; // a day of walking
    }
    let cam = camera(Vec3::new(0.0, 60.0, -60.0), Vec3::ZERO, 800.0, 600.0);
    let lookup = ViewLookup::new(&directions(24, Coverage::UpperHemisphere));
    let clip = ClipTiming { frames: 10, fps: 10.0 };
    crowd.select(&cam, &LodPolicy::Only(Level::Impostor), &lookup, clip);
    // Wrapped to within 64 loops of the 1 s clip.
    assert!(
        crowd.agents.clock.iter().all(|&c| (0.0..64.0).contains(&c)),
        "{:?}",
        crowd.agents.clock
    );
    for inst in &crowd.instances[0][Level::Impostor as usize] {
        let (f0, f1) = frame_pair_parts(inst.frame);
        assert!(f0 < 10 && f1 < 10 && (0.0..1.0).contains(&inst.blend));
    }
}

fn span(name: &str, start: u32, frames: u32, ground_speed: f32) -> crate::timeline::ClipSpan {
    crate::timeline::ClipSpan {
        name: name.into(),
        start,
        frames,
        looping: true,
        ground_speed,
        secs_per_frame: 0.0,
    }
}

/// Walk (10 frames, 1.2 m/s), Run (7, 3.0 m/s), Idle (20, still), Wave (20, a sway).
fn four_clips() -> Vec<crate::timeline::ClipSpan> {
    vec![
        span("Walk", 0, 10, 1.2),
        span("Run", 10, 7, 3.0),
        span("Idle", 17, 20, 0.0),
        span("Wave", 37, 20, 0.05),
    ]
}

#[test]
fn clips_sort_into_walk_run_and_idle_by_measured_speed() {
    let g = Gaits::new(&four_clips(), 10.0);
    assert_eq!((g.walk, g.run, g.idle.clone()), (Some(0), Some(1), vec![2, 3]));
    // A "run" barely faster than the walk is no run; with nothing moving, nothing walks.
    let mut close = four_clips();
    close[1].ground_speed = 1.4;
    let g = Gaits::new(&close, 10.0);
    assert_eq!((g.walk, g.run), (Some(0), None));
    // A fall that does not loop is not stood in while a looping idle exists.
    let mut fall = four_clips();
    fall.push(span("Death", 57, 10, 0.0));
    fall[4].looping = false;
    assert_eq!(Gaits::new(&fall, 10.0).idle, vec![2, 3]);
    let roles: Vec<Option<Gait>> = (0..5).map(|i| Gaits::new(&fall, 10.0).role(i)).collect();
    assert_eq!(
        roles,
        [
            Some(Gait::Walk),
            Some(Gait::Run),
            Some(Gait::Idle),
            Some(Gait::Idle),
            None
        ]
    );
    let still = vec![span("Idle", 0, 20, 0.0)];
    let g = Gaits::new(&still, 10.0);
    assert_eq!((g.walk, g.run, g.idle.clone()), (None, None, vec![0]));
    assert_eq!(g.clip_for(Gait::Idle, 0.3), Some(0));
    assert_eq!(g.clip_for(Gait::Walk, 0.3), None);
}

#[test]
fn agents_walk_run_and_stand_in_their_shares_with_their_feet_on_the_ground() {
    let clips = four_clips();
    let mut crowd = Crowd::new(CrowdParams {
        count: 3000,
        seed: 5,
        ..Default::default()
    });
    crowd.set_clips(&clips, 10.0);
    // Shares as asked (0.6, 0.2, 0.2), within sampling error.
    let n = crowd.gait_counts();
    let total = crowd.len() as f32;
    for (k, want) in [0.6f32, 0.2, 0.2].into_iter().enumerate() {
        assert!((n[k] as f32 / total - want).abs() < 0.04, "gait {k}: {n:?}");
    }
    let a = &crowd.agents;
    for i in 0..crowd.len() {
        let c = &clips[a.clip[i] as usize];
        match a.gait[i] {
            Gait::Walk => assert_eq!(c.name, "Walk"),
            Gait::Run => assert_eq!(c.name, "Run"),
            Gait::Idle => assert!(c.name == "Idle" || c.name == "Wave"),
        }
        // Speed about the clip's own, none standing in a moving clip.
        let s = a.speed[i];
        if a.gait[i] == Gait::Idle {
            assert_eq!(s, 0.0);
        } else {
            assert!(
                (s / c.ground_speed - 1.0).abs() <= SPEED_SPREAD + 1e-4,
                "{s} in {}",
                c.name
            );
        }
    }
    // Brute force, step by step: an agent that keeps its clip moves exactly as far as its
    // clip's frames carry the ground (clock × ground speed), so its feet do not slide; one
    // standing does not move.
    let cam = camera(Vec3::new(0.0, 300.0, -300.0), Vec3::ZERO, 800.0, 600.0);
    let lookup = ViewLookup::new(&directions(24, Coverage::UpperHemisphere));
    let timing = ClipTiming { frames: 57, fps: 10.0 };
    let mut checked = 0;
    for _ in 0..60 {
        let before = crowd.agents.clone();
        crowd.simulate(0.05);
        let a = &crowd.agents;
        for i in 0..crowd.len() {
            if a.clip[i] != before.clip[i] {
                continue;
            }
            let moved = a.pos[i].distance(before.pos[i]);
            let c = &clips[a.clip[i] as usize];
            if a.gait[i] == Gait::Idle {
                assert_eq!(moved, 0.0, "agent {i} idles in place");
            } else {
                let carried = (a.clock[i] - before.clock[i]) * c.ground_speed;
                assert!(
                    (moved - carried).abs() < 1e-4 * (1.0 + moved),
                    "agent {i}: moved {moved}, feet carried {carried}"
                );
                checked += 1;
            }
        }
        // Every record plays frames of its own clip, blending towards the next in that clip.
        crowd.select_over(&cam, &LodPolicy::Only(Level::Polypostor), &lookup, timing, 0.05);
        for inst in &crowd.instances[0][Level::Polypostor as usize] {
            let (f0, f1) = frame_pair_parts(inst.frame);
            let c = clips.iter().find(|c| c.range().contains(&(f0 as usize))).unwrap();
            assert!(
                c.range().contains(&(f1 as usize)),
                "{f0} -> {f1} leaves clip {}",
                c.name
            );
            assert_eq!(f1 as usize, crate::timeline::next_frame(&clips, f0 as usize));
        }
    }
    assert!(checked > 10_000, "{checked}");
}

#[test]
fn a_change_of_clip_cross_fades_between_the_two_clips() {
    let clips = four_clips();
    let mut crowd = Crowd::new(CrowdParams {
        count: 200,
        seed: 6,
        behaviour: Behaviour {
            walk: 1.0,
            run: 0.0,
            idle: 0.0,
        },
        ..Default::default()
    });
    crowd.set_clips(&clips, 10.0);
    assert_eq!(crowd.gait_counts(), [200, 0, 0]);
    let cam = camera(Vec3::new(0.0, 200.0, -200.0), Vec3::ZERO, 800.0, 600.0);
    let lookup = ViewLookup::new(&directions(24, Coverage::UpperHemisphere));
    let timing = ClipTiming { frames: 57, fps: 10.0 };
    let policy = LodPolicy::Only(Level::Skinned);
    crowd.select_over(&cam, &policy, &lookup, timing, 0.05);
    let seen = crowd.instances[0][Level::Skinned as usize].len();
    assert!(seen > 100);
    // Everyone breaks into a run now.
    crowd.params.behaviour = Behaviour {
        walk: 0.0,
        run: 1.0,
        idle: 0.0,
    };
    for t in &mut crowd.agents.gait_timer {
        *t = 0.0;
    }
    crowd.simulate(0.05);
    assert_eq!(crowd.gait_counts(), [0, 200, 0]);
    crowd.select_over(&cam, &policy, &lookup, timing, 0.05);
    let list = &crowd.instances[0][Level::Skinned as usize];
    assert_eq!(
        list.len(),
        2 * seen,
        "every agent drawn twice while its clips cross-fade"
    );
    for pair in list.chunks(2) {
        let (out, inc) = (pair[0], pair[1]);
        let (o, _) = frame_pair_parts(out.frame);
        let (n, _) = frame_pair_parts(inc.frame);
        assert!(clips[0].range().contains(&(o as usize)), "the walk fades out");
        assert!(clips[1].range().contains(&(n as usize)), "the run fades in");
        for k in 0..16 {
            let d = (k as f32 + 0.5) / 16.0;
            assert_ne!(
                fade_keeps(out.variant, d),
                fade_keeps(inc.variant, d),
                "complementary dither"
            );
        }
    }
    // After the fade time, one copy each again.
    for _ in 0..10 {
        crowd.simulate(0.05);
        crowd.select_over(&cam, &policy, &lookup, timing, 0.05);
    }
    assert_eq!(crowd.instances[0][Level::Skinned as usize].len(), seen);
}

#[test]
fn sort_by_view_groups_every_instance_under_its_view() {
    let mut rng = super::rng::Rng::new(9);
    let instances: Vec<Instance> = (0..500)
        .map(|k| Instance {
            view: rng.below(40) as u32,
            frame: rng.below(30) as u32,
            variant: k,
            ..Default::default()
        })
        .collect();
    let (mut out, mut ranges) = (Vec::new(), Vec::new());
    // 32 views: views 32..40 clamp to 31; 10 frames: frames wrap.
    sort_by_view(&instances, 32, 10, &mut out, &mut ranges);
    assert_eq!(out.len(), instances.len());
    assert_eq!(ranges.len(), 32);
    for (v, r) in ranges.iter().enumerate() {
        for i in &out[r.start as usize..r.end as usize] {
            assert_eq!(i.view as usize, v);
            assert!(i.frame < 10);
        }
    }
    assert_eq!(ranges.last().unwrap().end as usize, out.len());
    // Nothing lost, nothing doubled: every variant once, in input order within a view.
    let mut seen: Vec<u32> = out.iter().map(|i| i.variant).collect();
    seen.sort_unstable();
    assert_eq!(seen, (0..500).collect::<Vec<_>>());
    for r in &ranges {
        let s = &out[r.start as usize..r.end as usize];
        assert!(s.windows(2).all(|w| w[0].variant < w[1].variant), "stable");
    }
    for (a, b) in instances.iter().zip(0..) {
        let found = out.iter().find(|i| i.variant == b).unwrap();
        assert_eq!(found.view, a.view.min(31));
        assert_eq!(found.frame, a.frame % 10);
    }
}

/// A crowd of a character `k` times bigger (or smaller) is the same crowd `k` times bigger:
/// the same agents at `k` times the positions, the same frames, views and levels seen from a
/// camera `k` times further away. Powers of two, so every product is exact in floating point
/// and the two runs take the same random decisions.
#[test]
fn a_crowd_of_any_size_is_the_reference_crowd_scaled() {
    let base = CharacterSize::from_bounds(Vec3::new(-0.3, 0.0, -0.2), Vec3::new(0.3, 1.75, 0.25));
    let views = ViewLookup::new(&directions(137, Coverage::UpperHemisphere));
    let clip = ClipTiming { frames: 12, fps: 10.0 };
    let policy = LodPolicy::Mixed(LodDistances::default());
    let run = |k: f32| {
        let size = CharacterSize::from_bounds(Vec3::new(-0.3, 0.0, -0.2) * k, Vec3::new(0.3, 1.75, 0.25) * k);
        assert_eq!(size.scale(), base.scale() * k);
        let params = CrowdParams {
            seed: 5,
            ..CrowdParams::for_character(1500, size, Some(2.0 * k))
        };
        assert_eq!(
            params.min_distance,
            CrowdParams::default().min_distance * base.scale() * k
        );
        let mut crowd = Crowd::new(params);
        let cam = camera(Vec3::new(3.0, 6.0, -40.0) * k, Vec3::new(0.0, 0.0, 0.0), 1600.0, 900.0);
        let mut out = Vec::new();
        for _ in 0..40 {
            crowd.simulate(1.0 / 30.0);
            crowd.select(&cam, &policy, &views, clip);
            out.push(crowd.instances[0].clone());
        }
        (crowd.half_extent, out)
    };
    let (h1, one) = run(1.0);
    assert!(
        one.iter()
            .any(|levels| levels.iter().filter(|l| !l.is_empty()).count() >= 2),
        "one level only"
    );
    for k in [4.0f32, 1.0 / 64.0] {
        let (hk, other) = run(k);
        assert_eq!(hk, h1 * k);
        for (a, b) in one.iter().zip(&other) {
            for (la, lb) in a.iter().zip(b) {
                assert_eq!(la.len(), lb.len(), "scale {k}");
                for (x, y) in la.iter().zip(lb) {
                    assert_eq!([x.pos[0] * k, x.pos[1] * k], y.pos, "scale {k}");
                    assert_eq!(
                        (x.view, x.frame, x.facing, x.variant),
                        (y.view, y.frame, y.facing, y.variant)
                    );
                    assert!(
                        (x.blend - y.blend).abs() < 1e-4,
                        "scale {k}: {} against {}",
                        x.blend,
                        y.blend
                    );
                }
            }
        }
    }
}

/// The reference person's sizes give the crowd's defaults; the default character measures
/// about as tall as a person and stands on the ground.
#[test]
fn the_reference_person_keeps_the_defaults_and_the_default_character_measures_right() {
    let p = CrowdParams::for_character(1000, CharacterSize::reference(), Some(1.8));
    let d = CrowdParams::default();
    assert_eq!(
        (p.density, p.min_distance, p.speed, p.stride_speed),
        (d.density, d.min_distance, d.speed, d.stride_speed)
    );
    let c = crate::default_character::generate();
    let clip = c.find_clip("Walk");
    let size = CharacterSize::measure(&c, clip);
    assert!((1.4..2.2).contains(&size.height), "{size:?}");
    assert!(size.ground_y.abs() < 0.1, "{size:?}");
    assert!((0.75..1.25).contains(&size.scale()), "{size:?}");
    // Nonsense bounds fall back to the reference instead of a zero or infinite size.
    assert_eq!(
        CharacterSize::from_bounds(Vec3::ZERO, Vec3::ZERO),
        CharacterSize::reference()
    );
    assert_eq!(
        CharacterSize::from_bounds(Vec3::splat(f32::NAN), Vec3::ONE),
        CharacterSize::reference()
    );
}

/// A character crossing a level switch, or turning into the next baked view, is drawn twice
/// for `fade_secs`: the new level (view) dithered in, the old one out, with complementary
/// bits (`fade_keeps` of the two covers every threshold exactly once); then once again.
/// `select` (no time step) cuts.
#[test]
fn level_and_view_switches_cross_fade_for_the_fade_time() {
    let params = CrowdParams {
        count: 1,
        fade_secs: 0.25,
        seed: 4,
        ..Default::default()
    };
    let views = ViewLookup::new(&directions(137, Coverage::UpperHemisphere));
    let clip = ClipTiming { frames: 10, fps: 10.0 };
    let policy = LodPolicy::Mixed(LodDistances::default());
    let mut crowd = Crowd::new(params);
    let at = crowd.agents.pos[0];
    let target = Vec3::new(at.x, 0.9, at.y);
    let cam = |d: f32, angle: f32| {
        let eye = target + Vec3::new(angle.sin() * d, 0.5, angle.cos() * d);
        camera(eye, target, 800.0, 600.0)
    };
    let copies = |c: &Crowd| -> Vec<(Level, Instance)> {
        Level::ALL
            .iter()
            .flat_map(|&l| c.instances[0][l as usize].iter().map(move |i| (l, *i)))
            .collect()
    };
    let complementary = |a: u32, b: u32| {
        (0..16).all(|k| {
            let d = (k as f32 + 0.5) / 16.0;
            crate::crowd::fade_keeps(a, d) != crate::crowd::fade_keeps(b, d)
        })
    };
    // Far: the impostor. The first selection never fades.
    crowd.select_over(&cam(200.0, 0.0), &policy, &views, clip, 1.0 / 30.0);
    assert_eq!(copies(&crowd).len(), 1);
    assert_eq!(copies(&crowd)[0].0, Level::Impostor);
    // Near enough for the Polypostor: two copies for 0.5 s (a level fade is twice a view's).
    let dt = 1.0 / 30.0;
    let mut frames_faded = 0;
    for step in 0..30 {
        crowd.select_over(&cam(20.0, 0.0), &policy, &views, clip, dt);
        let c = copies(&crowd);
        if step == 0 {
            assert_eq!(c.len(), 2, "{c:?}");
            let new = c.iter().find(|x| x.0 == Level::Polypostor).expect("incoming copy");
            let old = c.iter().find(|x| x.0 == Level::Impostor).expect("outgoing copy");
            assert!(complementary(new.1.variant, old.1.variant));
            assert_eq!(new.1.variant & VARIANT_SEED_MASK, old.1.variant & VARIANT_SEED_MASK);
        }
        if c.len() == 2 {
            frames_faded += 1;
        } else {
            assert_eq!(c.len(), 1);
            assert_eq!(c[0].0, Level::Polypostor);
            assert_eq!(c[0].1.variant >> 24, 0, "drawn whole after the fade");
        }
    }
    // 0.5 s at 30 frames a second: 15 frames (the last at t = 14/15).
    assert_eq!(LEVEL_FADE_SCALE, 2.0);
    assert_eq!(frames_faded, 15);
    // Turning round the character at the same distance: the view changes, and fades.
    let before = copies(&crowd)[0].1.view;
    let mut angle = 0.0f32;
    let mut saw_view_fade = false;
    while angle < 1.0 {
        angle += 0.02;
        crowd.select_over(&cam(20.0, angle), &policy, &views, clip, dt);
        let c = copies(&crowd);
        if c.len() == 2 {
            assert!(c.iter().all(|x| x.0 == Level::Polypostor));
            assert_ne!(c[0].1.view, c[1].1.view);
            assert!(complementary(c[0].1.variant, c[1].1.variant));
            saw_view_fade = true;
        }
    }
    assert!(saw_view_fade, "no view change from view {before}");
    // Out of view for a frame (the camera looks away), then back nearer, from another side:
    // nothing on screen to fade from, so one copy.
    let away = camera(
        target + Vec3::new(0.0, 0.5, 20.0),
        target + Vec3::new(0.0, 0.5, 40.0),
        800.0,
        600.0,
    );
    crowd.select_over(&away, &policy, &views, clip, dt);
    assert!(copies(&crowd).is_empty(), "culled");
    crowd.select_over(&cam(4.0, 2.5), &policy, &views, clip, dt);
    let c = copies(&crowd);
    assert_eq!(c.len(), 1, "{c:?}");
    assert_eq!(c[0].1.variant >> 24, 0);
    // `select` cuts: one copy whatever changed.
    crowd.select(&cam(200.0, 0.0), &policy, &views, clip);
    assert_eq!(copies(&crowd).len(), 1);
    // The dither rule: q of 128 thresholds kept by the incoming copy, the rest by the other.
    for t in [0.0f32, 0.3, 0.5, 0.99] {
        let kept = (0..128)
            .filter(|&k| crate::crowd::fade_keeps(fade_bits(t, false), (k as f32 + 0.5) / 128.0))
            .count();
        let q = ((t * 128.0).round() as usize).clamp(1, 127);
        assert_eq!(kept, q, "t {t}");
    }
    assert_eq!(fade_bits(1.0, false), 0);
    assert_eq!(fade_bits(1.5, true), 0);
}

/// Thinning a crowd too heavy for the machine: at most the budget is kept (and no fewer than
/// the budget less one character's records), a character's records — both copies of a
/// cross-fade, in one level's list or two — are kept or dropped together, who is kept does not
/// depend on the lists' order, and every level keeps about the same share; the budget halves
/// on slow frames down to a floor and grows back to "everyone" on fast ones.
#[test]
fn a_crowd_too_heavy_for_the_machine_thins_out_evenly_and_recovers() {
    use crate::scene::{FAST_FRAME_SECS, MIN_DRAWN, SLOW_FRAME_SECS, next_budget, thin_out};
    let mut rng = crate::crowd::Rng::new(7);
    for (characters, budget) in [(20_000usize, 5_000usize), (7, 5), (10, 100), (3_000, 2_999)] {
        // Records (character id, seed): a quarter of the characters fade, drawn twice, the
        // second copy in another level's list.
        let seeds: Vec<u32> = (0..characters)
            .map(|_| rng.next_u64() as u32 & VARIANT_SEED_MASK)
            .collect();
        let mut lists: Vec<Vec<(usize, u32)>> = vec![Vec::new(); 3];
        for (c, &seed) in seeds.iter().enumerate() {
            lists[c % 3].push((c, seed));
            if c % 4 == 0 {
                lists[(c + 1) % 3].push((c, seed));
            }
        }
        let total: usize = lists.iter().map(Vec::len).sum();
        let sizes: Vec<usize> = lists.iter().map(Vec::len).collect();
        let mut reversed: Vec<Vec<(usize, u32)>> =
            lists.iter().rev().map(|l| l.iter().rev().copied().collect()).collect();
        let dropped = thin_out(&mut lists, budget, |r| r.1);
        let kept: usize = lists.iter().map(Vec::len).sum();
        assert_eq!(kept + dropped, total);
        if total <= budget {
            assert_eq!(dropped, 0);
            continue;
        }
        assert!(kept <= budget && kept + 1 >= budget, "{kept} of {total} for {budget}");
        // Brute force: a character is drawn whole or not at all, and the kept ones are those
        // with the smallest seeds.
        let mut copies = vec![0usize; characters];
        for &(c, _) in lists.iter().flatten() {
            copies[c] += 1;
        }
        for c in 0..characters {
            let whole = 1 + (c % 4 == 0) as usize;
            assert!(
                copies[c] == 0 || copies[c] == whole,
                "character {c}: {} of {whole}",
                copies[c]
            );
        }
        let largest_kept = lists.iter().flatten().map(|r| r.1).max().unwrap_or(0);
        let smallest_dropped = (0..characters)
            .filter(|&c| copies[c] == 0)
            .map(|c| seeds[c])
            .min()
            .unwrap();
        assert!(largest_kept < smallest_dropped);
        // The same characters whatever the order.
        thin_out(&mut reversed, budget, |r| r.1);
        let mut a: Vec<usize> = lists.iter().flatten().map(|r| r.0).collect();
        let mut b: Vec<usize> = reversed.iter().flatten().map(|r| r.0).collect();
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b);
        // Each level about the same share (random seeds: within a few standard deviations).
        let r = budget as f64 / total as f64;
        for (list, &n) in lists.iter().zip(&sizes) {
            let share = list.len() as f64 / n as f64;
            let sigma = (r * (1.0 - r) / n as f64).sqrt();
            assert!((share - r).abs() <= 5.0 * sigma + 1.0 / n as f64, "{share} against {r}");
        }
    }
    // Slow frames halve (never below the floor); fast ones grow back to everyone.
    let mut b = usize::MAX;
    for _ in 0..20 {
        b = next_budget(b, SLOW_FRAME_SECS + 0.05, 20_000);
    }
    assert_eq!(b, MIN_DRAWN);
    assert_eq!(
        next_budget(usize::MAX, (SLOW_FRAME_SECS + FAST_FRAME_SECS) / 2.0, 20_000),
        usize::MAX
    );
    let mut steps = 0;
    while b != usize::MAX {
        b = next_budget(b, FAST_FRAME_SECS / 2.0, 20_000);
        steps += 1;
        assert!(steps < 100);
    }
    // A small crowd is never thinned.
    assert_eq!(next_budget(usize::MAX, 1.0, MIN_DRAWN), usize::MAX);
    // The slower the frame, the more is dropped at once (at most half kept).
    assert!(next_budget(10_000, 2.0, 10_000) < next_budget(10_000, 0.2, 10_000));
    assert_eq!(next_budget(10_000, 0.16, 10_000), 5_000);
}

#[test]
fn the_behaviour_shares_hold_as_agents_change_gait() {
    let mut crowd = Crowd::new(CrowdParams {
        count: 2000,
        seed: 8,
        ..Default::default()
    });
    crowd.set_clips(&four_clips(), 10.0);
    // Two minutes: every agent has changed gait many times (spells of 2 to 12 s).
    let mut changes = 0usize;
    for _ in 0..1200 {
        let before = crowd.agents.gait.clone();
        crowd.simulate(0.1);
        changes += before.iter().zip(&crowd.agents.gait).filter(|(a, b)| a != b).count();
    }
    assert!(changes > 10_000, "{changes} gait changes");
    let n = crowd.gait_counts();
    let total = crowd.len() as f32;
    for (k, want) in [0.6f32, 0.2, 0.2].into_iter().enumerate() {
        assert!((n[k] as f32 / total - want).abs() < 0.05, "gait {k}: {n:?}");
    }
}

/// A second character: a long-bodied quadruped-like one, 0.9 m tall and 2.4 m long (so
/// bigger than the person by its length), walking at 2.0 and trotting at 3.5 units/s, its
/// clips at 12 fps and 40 baked views.
fn beast() -> Species {
    let size = CharacterSize::from_bounds(Vec3::new(-0.3, 0.0, -1.2), Vec3::new(0.3, 0.9, 1.2));
    let clips = vec![
        span("Pace", 0, 16, 2.0),
        span("Trot", 16, 9, 3.5),
        span("Sniff", 25, 30, 0.0),
    ];
    Species::new(
        size,
        None,
        &clips,
        &directions(40, Coverage::UpperHemisphere),
        ClipTiming { frames: 55, fps: 12.0 },
    )
}

/// Two characters in one crowd: agents dealt out in the shares asked (exactly, at random
/// places), each walking its own character's clips at their speeds with feet on the ground
/// (brute force per agent per step), drawn from its own kind's lists with its own frames and
/// views, each pair of agents the mean of their characters' spacings apart (brute force over
/// every pair) on a ground sized for the shares; bad mixes are refused.
#[test]
fn two_characters_share_a_crowd_in_their_shares_each_walking_its_own_clips() {
    let person = four_clips();
    let beast = beast();
    let mut params = CrowdParams {
        count: 2000,
        seed: 21,
        ..Default::default()
    };
    let mut largest = params.clone();
    largest.spaced_for(&beast.size);
    params.spaced_for_shares(&[beast.size], &[3.0, 1.0]);
    let s_beast = beast.size.scale() / params.size.scale();
    assert!(s_beast > 1.3, "the beast is the larger: {s_beast}");
    assert!(
        (params.min_distance / CrowdParams::default().min_distance - s_beast).abs() < 1e-5,
        "the grid's cell is the beast's spacing"
    );
    // Ground per agent: 3/4 of a person's, 1/4 of the beast's (its scale² times a person's).
    let expected =
        1.0 / (0.75 / CrowdParams::default().density + 0.25 * s_beast * s_beast / CrowdParams::default().density);
    assert!(
        (params.density / expected - 1.0).abs() < 1e-4,
        "{} vs {expected}",
        params.density
    );
    assert!(
        params.density > 1.3 * largest.density,
        "the people are not spread out for the beast"
    );
    let mut crowd = Crowd::new(params.clone());
    crowd.set_clips(&person, 10.0);
    crowd.mix(vec![beast.clone()], &[3.0, 1.0]).unwrap();
    assert_eq!(crowd.kind_counts(), vec![1500, 500]);
    // Each kind's gaits counted apart add up to the crowd's.
    let (own, beasts) = (crowd.gait_counts_of(0), crowd.gait_counts_of(1));
    assert_eq!(own.iter().sum::<usize>(), 1500);
    assert_eq!(beasts.iter().sum::<usize>(), 500);
    let all = crowd.gait_counts();
    assert!(
        (0..3).all(|g| own[g] + beasts[g] == all[g]),
        "{own:?} {beasts:?} {all:?}"
    );
    assert_eq!(crowd.gait_counts_of(2), [0; 3]);
    // Dealt at random: the beasts are not one block of the ground.
    let beasts: Vec<Vec2> = (0..crowd.len())
        .filter(|&i| crowd.agents.kind[i] == 1)
        .map(|i| crowd.agents.pos[i])
        .collect();
    let mean = beasts.iter().copied().sum::<Vec2>() / beasts.len() as f32;
    assert!(mean.length() < 0.1 * crowd.half_extent, "beasts centred at {mean}");
    // Each kind's agents play their own clips at their own speeds.
    let g = beast.gaits.as_ref().unwrap();
    for i in 0..crowd.len() {
        let a = &crowd.agents;
        let clips = if a.kind[i] == 0 { &person } else { &g.clips };
        let c = &clips[a.clip[i] as usize];
        if a.gait[i] == Gait::Idle {
            assert_eq!(a.speed[i], 0.0);
        } else {
            assert!((a.speed[i] / c.ground_speed - 1.0).abs() <= SPEED_SPREAD + 1e-4);
        }
    }
    let cam = camera(Vec3::new(0.0, 200.0, -250.0), Vec3::ZERO, 800.0, 600.0);
    let person_views = ViewLookup::new(&directions(24, Coverage::UpperHemisphere));
    let timing = ClipTiming { frames: 57, fps: 10.0 };
    let mut checked = [0usize; 2];
    for _ in 0..40 {
        let before = crowd.agents.clone();
        crowd.simulate(0.05);
        let a = &crowd.agents;
        for i in 0..crowd.len() {
            if a.clip[i] != before.clip[i] || a.gait[i] == Gait::Idle {
                continue;
            }
            let k = a.kind[i] as usize;
            let c = if k == 0 {
                &person[a.clip[i] as usize]
            } else {
                &g.clips[a.clip[i] as usize]
            };
            let moved = a.pos[i].distance(before.pos[i]);
            let carried = (a.clock[i] - before.clock[i]) * c.ground_speed;
            assert!((moved - carried).abs() < 1e-4 * (1.0 + moved), "agent {i} (kind {k})");
            checked[k] += 1;
        }
        crowd.select_over(&cam, &LodPolicy::Only(Level::Impostor), &person_views, timing, 0.05);
        assert_eq!(crowd.instances.len(), 2);
        for (k, lists) in crowd.instances.iter().enumerate() {
            let (clips, views) = if k == 0 { (&person, 24) } else { (&g.clips, 40) };
            for inst in &lists[Level::Impostor as usize] {
                let (f0, f1) = frame_pair_parts(inst.frame);
                assert_eq!(f1 as usize, crate::timeline::next_frame(clips, f0 as usize), "kind {k}");
                assert!(inst.view < views, "kind {k}: view {}", inst.view);
            }
        }
    }
    assert!(checked[0] > 5_000 && checked[1] > 1_000, "{checked:?}");
    // Each pair the mean of their spacings apart, whoever stands next to whom (every pair),
    // and people do come closer to each other than the beast's spacing.
    let spacing = |k: u8| params.min_distance * if k == 0 { 1.0 / s_beast } else { 1.0 };
    let (pos, kind) = (&crowd.agents.pos, &crowd.agents.kind);
    let mut closest_people = f32::INFINITY;
    for i in 0..pos.len() {
        for j in i + 1..pos.len() {
            let d = pos[i].distance(pos[j]);
            let need = 0.5 * (spacing(kind[i]) + spacing(kind[j]));
            assert!(
                d >= need * (1.0 - 1e-5),
                "agents {i}, {j} (kinds {}, {}): {d} < {need}",
                kind[i],
                kind[j]
            );
            if kind[i] == 0 && kind[j] == 0 {
                closest_people = closest_people.min(d);
            }
        }
    }
    assert!(
        closest_people < 0.9 * params.min_distance,
        "people keep their own spacing, not the beast's: closest {closest_people}"
    );
    // Refused: share count, negative or all-zero shares, too many characters.
    for shares in [&[1.0][..], &[1.0, -1.0], &[0.0, 0.0], &[1.0, f32::NAN]] {
        assert!(crowd.mix(vec![beast.clone()], shares).is_err(), "{shares:?}");
    }
    assert!(
        crowd
            .mix(vec![beast.clone(); MAX_SPECIES], &[1.0; MAX_SPECIES + 1])
            .is_err()
    );
    // Dealt out again where they stand, with more beasts: pairs now too close for their new
    // spacing only move apart, and every other pair keeps its spacing (every pair, each step).
    crowd.mix(vec![beast.clone()], &[1.0, 3.0]).unwrap();
    let gaps = |crowd: &Crowd| {
        let (pos, kind) = (&crowd.agents.pos, &crowd.agents.kind);
        let mut out = Vec::new();
        for i in 0..pos.len() {
            for j in i + 1..pos.len() {
                out.push((pos[i].distance(pos[j]), 0.5 * (spacing(kind[i]) + spacing(kind[j]))));
            }
        }
        out
    };
    let mut before = gaps(&crowd);
    let too_close = before.iter().filter(|(d, need)| *d < need * (1.0 - 1e-5)).count();
    assert!(
        too_close > 0,
        "re-dealing made no pair too close: the check below tests nothing"
    );
    for step in 0..10 {
        crowd.simulate(0.05);
        let now = gaps(&crowd);
        for (k, (&(d, need), &(was, _))) in now.iter().zip(&before).enumerate() {
            assert!(
                d >= need * (1.0 - 1e-5) || d >= was * (1.0 - 1e-5),
                "step {step}, pair {k}: {was} -> {d} < {need}"
            );
        }
        before = now;
    }
    // All of one kind: everyone is the beast.
    crowd.mix(vec![beast.clone()], &[0.0, 1.0]).unwrap();
    assert_eq!(crowd.kind_counts(), vec![0, 2000]);
}

/// In a mix of packs baked at different resolutions, each character's level comes from its
/// own pixel-to-texel ratio: brute force per visible agent against the policy fed the
/// ratio worked out here (a 64-texel copy of the person switches at half the distance).
#[test]
fn each_character_switches_level_at_its_own_bake_resolution() {
    let person = four_clips();
    let params = CrowdParams {
        count: 600,
        seed: 4,
        ..Default::default()
    };
    let mut crowd = Crowd::new(params.clone());
    crowd.set_clips(&person, 10.0);
    let views24 = directions(24, Coverage::UpperHemisphere);
    let copy = Species {
        texels: 64.0,
        ..Species::new(
            params.size,
            Some(params.height),
            &person,
            &views24,
            ClipTiming { frames: 57, fps: 10.0 },
        )
    };
    crowd.mix(vec![copy], &[1.0, 1.0]).unwrap();
    let policy = LodPolicy::Mixed(LodDistances::default());
    let eye = Vec3::new(0.0, 6.0, -crowd.half_extent - 4.0);
    let (w, h) = (1600.0, 900.0);
    let cam = camera(eye, Vec3::ZERO, w, h);
    crowd.select(
        &cam,
        &policy,
        &ViewLookup::new(&views24),
        ClipTiming { frames: 57, fps: 10.0 },
    );
    let mut checked = [[0usize; 3]; 2];
    for (k, lists) in crowd.instances.iter().enumerate() {
        for (slot, level) in [Level::Skinned, Level::Polypostor, Level::Impostor]
            .into_iter()
            .enumerate()
        {
            for inst in &lists[level as usize] {
                let i = (0..crowd.len())
                    .find(|&i| crowd.agents.pos[i] == Vec2::from(inst.pos))
                    .unwrap();
                assert_eq!(crowd.agents.kind[i] as usize, k);
                let centre = Vec3::new(inst.pos[0], params.size.centre.y, inst.pos[1]);
                let distance = (eye - centre).length().max(1e-3);
                let pixels = params.height * cam.focal_px / distance * if k == 1 { 2.0 } else { 1.0 };
                assert_eq!(policy.choose(pixels, Level::Polypostor), level, "kind {k}, {pixels} px");
                checked[k][slot] += 1;
            }
        }
    }
    // Many agents checked; the low-resolution copy stays a mesh further out.
    let total: usize = checked.iter().flatten().sum();
    assert!(total > 200, "{checked:?}");
    assert!(
        checked[1][0] > checked[0][0],
        "the low-resolution copy is a mesh further out: {checked:?}"
    );
}

/// The selection split into runs on the thread pool gives exactly what one pass over every
/// agent gives: the same instance lists in the same order and the same agent state, frame
/// after frame, with two kinds of character, clip changes and level and view cross-fades.
#[test]
fn selecting_in_parallel_runs_gives_exactly_the_serial_selection() {
    let person = four_clips();
    let make = |run: usize| {
        let mut params = CrowdParams {
            count: 3000,
            seed: 33,
            fade_secs: 0.25,
            ..Default::default()
        };
        params.spaced_for(&beast().size);
        let mut crowd = Crowd::new(params);
        crowd.set_clips(&person, 10.0);
        crowd.mix(vec![beast()], &[2.0, 1.0]).unwrap();
        crowd.select_run = run;
        crowd
    };
    let (mut serial, mut parallel) = (make(usize::MAX), make(37));
    let views = ViewLookup::new(&directions(137, Coverage::UpperHemisphere));
    let clip = ClipTiming { frames: 40, fps: 10.0 };
    let policy = LodPolicy::Mixed(LodDistances::default());
    let reach = serial.half_extent;
    let mut faded = 0;
    for step in 0..60 {
        // The camera sweeps in and round, so levels and views change under it.
        let t = step as f32 / 60.0;
        let d = reach * (1.5 - 1.3 * t);
        let eye = Vec3::new((3.0 * t).sin() * d, 2.0 + 10.0 * t, (3.0 * t).cos() * d);
        let cam = camera(eye, Vec3::ZERO, 1280.0, 720.0);
        let a = serial.frame(1.0 / 30.0, &cam, &policy, &views, clip);
        let b = parallel.frame(1.0 / 30.0, &cam, &policy, &views, clip);
        assert_eq!((a.visible, a.per_level), (b.visible, b.per_level), "step {step}");
        assert_eq!(serial.instances, parallel.instances, "step {step}");
        let (x, y) = (&serial.agents, &parallel.agents);
        assert_eq!(x.level, y.level);
        assert_eq!(x.view, y.view);
        assert_eq!(x.clock, y.clock);
        assert_eq!(x.fade, y.fade);
        assert_eq!(x.fade_from, y.fade_from);
        assert_eq!(x.seen, y.seen);
        assert_eq!(x.clip_from, y.clip_from);
        faded += serial
            .instances
            .iter()
            .flatten()
            .flatten()
            .filter(|i| i.variant >> 24 != 0)
            .count();
        assert!(a.visible > 0, "step {step}: nothing in view");
    }
    assert!(
        faded > 100,
        "the sweep made {faded} cross-fading copies: it tests too little"
    );
}

/// New shares of a mix keep the ground while it still fits (a few more or fewer big
/// characters), and ask for the ground a fresh layout for them gets once they tip the mix
/// (most agents now the big character), keeping everything but the spacing.
#[test]
fn new_shares_lay_out_a_new_ground_only_when_the_old_one_no_longer_fits() {
    let beast = beast();
    let own = CrowdParams {
        count: 3000,
        seed: 5,
        behaviour: Behaviour {
            walk: 0.2,
            run: 0.7,
            idle: 0.1,
        },
        ..Default::default()
    };
    let mut laid = own.clone();
    laid.spaced_for_shares(&[beast.size], &[0.9, 0.1]);
    assert_eq!(laid.respaced_for_shares(&own, &[beast.size], &[0.9, 0.1]), None);
    // 10 % → 15 % beasts: the ground per agent grows by about 4 %.
    assert_eq!(laid.respaced_for_shares(&own, &[beast.size], &[0.85, 0.15]), None);
    // 90 % beasts: about 60 % more ground per agent.
    let relaid = laid
        .respaced_for_shares(&own, &[beast.size], &[0.1, 0.9])
        .expect("a mix of mostly beasts needs more ground");
    let mut fresh = own.clone();
    fresh.spaced_for_shares(&[beast.size], &[0.1, 0.9]);
    assert_eq!(
        relaid, fresh,
        "the new layout is the one a fresh mix in those shares gets"
    );
    assert!(
        relaid.density < 0.7 * laid.density,
        "{} vs {}",
        relaid.density,
        laid.density
    );
    // And back: from a ground for mostly beasts, a mix of mostly people asks for less.
    let back = relaid
        .respaced_for_shares(&own, &[beast.size], &[0.9, 0.1])
        .expect("a mix of mostly people needs less ground");
    assert_eq!(back, laid);
}
