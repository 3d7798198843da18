//! Every way a glTF can store its data imports the same character; forged and truncated
//! files fail cleanly; interpolation modes round-trip.

mod common;

use glam::{Quat, Vec3};
use polypostor::animation::{Pose, skin_vertices};
use polypostor::character::{ChannelValues, Interpolation};
use polypostor::gltf_write::{BufferStorage, write_glb, write_gltf};
use polypostor::import::import_slice;

fn small_character() -> polypostor::Character {
    polypostor::default_character::generate()
}

#[test]
fn glb_data_uri_and_external_buffer_import_identically() {
    let c = small_character();
    let from_glb = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();

    let embedded = write_gltf(&c, &BufferStorage::DataUri).unwrap();
    let from_data_uri = import_slice(embedded.json.as_bytes(), None, "x").unwrap();

    let dir = common::temp_dir("external");
    let external = write_gltf(&c, &BufferStorage::External("body%20data.bin".into())).unwrap();
    std::fs::write(dir.join("body data.bin"), external.bin.unwrap()).unwrap();
    std::fs::write(dir.join("c.gltf"), &external.json).unwrap();
    let from_file = polypostor::import_path(&dir.join("c.gltf")).unwrap();

    for other in [&from_data_uri, &from_file] {
        assert_eq!(other.vertices, from_glb.vertices);
        assert_eq!(other.indices, from_glb.indices);
        assert_eq!(other.clips, from_glb.clips);
        assert_eq!(other.textures, from_glb.textures);
    }
    // Without a folder, an external buffer is a clear error.
    let err = import_slice(external.json.as_bytes(), None, "x")
        .unwrap_err()
        .to_string();
    assert!(err.contains("external"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn step_and_cubic_spline_channels_survive_a_round_trip() {
    let mut c = small_character();
    // Replace the first clip's channels with a STEP translation and a CUBICSPLINE rotation.
    let head = c.skeleton.find("Head").unwrap();
    let hips = c.skeleton.find("Hips").unwrap();
    let rest = c.skeleton.nodes[hips].rest.translation;
    let q = Quat::from_rotation_y(0.8);
    c.clips[0].channels = vec![
        polypostor::character::Channel {
            node: hips,
            interpolation: Interpolation::Step,
            times: vec![0.0, 0.5, 1.0],
            values: ChannelValues::Translation(vec![rest, rest + Vec3::X * 0.3, rest]),
        },
        polypostor::character::Channel {
            node: head,
            interpolation: Interpolation::CubicSpline,
            times: vec![0.0, 1.0],
            values: ChannelValues::Rotation(vec![
                Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
                Quat::IDENTITY,
                Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
                Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
                q,
                Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
            ]),
        },
    ];
    let back = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    assert_eq!(back.clips[0].channels, c.clips[0].channels);
    let clip = &back.clips[0];
    let at = |t: f32| Pose::sample(&back, clip, t);
    assert_eq!(at(0.49).locals[hips].translation, rest);
    assert!((at(0.51).locals[hips].translation - (rest + Vec3::X * 0.3)).length() < 1e-6);
    // Zero tangents: smoothstep between identity and q, symmetric at the midpoint.
    let mid = at(0.5).locals[head].rotation;
    assert!(
        mid.angle_between(Quat::IDENTITY) > 0.3 && mid.angle_between(q) > 0.3,
        "{mid:?}"
    );
    let (p, _) = skin_vertices(&back, &at(0.25));
    assert!(p.iter().all(|v| v.is_finite()));
}

#[test]
fn forged_counts_and_truncations_fail_cleanly() {
    let glb = write_glb(&small_character()).unwrap();
    // Every truncation of the file fails with an error (and never panics).
    for cut in (0..glb.len()).step_by(997).chain([1, 11, 12, 19, 20, 21]) {
        let r = import_slice(&glb[..cut], None, "x");
        assert!(r.is_err(), "truncated at {cut} bytes should fail");
    }
    // Forge the first accessor's count to 2^31 inside the JSON chunk.
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json = std::str::from_utf8(&glb[20..20 + json_len]).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(json.trim_end()).unwrap();
    for (field, value) in [("count", 2_147_483_647u64), ("byteOffset", 4_000_000_000)] {
        let mut forged = v.clone();
        forged["accessors"][0][field] = serde_json::json!(value);
        let text = serde_json::to_string(&forged).unwrap();
        let err = import_slice(text.as_bytes(), None, "x").unwrap_err().to_string();
        assert!(!err.is_empty());
    }
    // An index pointing past the vertices is reported.
    let idx = v["meshes"][0]["primitives"][0]["indices"].as_u64().unwrap() as usize;
    v["accessors"][idx]["count"] = serde_json::json!(3);
    let positions = v["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize;
    v["accessors"][positions]["count"] = serde_json::json!(1);
    for (_, a) in v["meshes"][0]["primitives"][0]["attributes"]
        .as_object()
        .unwrap()
        .clone()
    {
        v["accessors"][a.as_u64().unwrap() as usize]["count"] = serde_json::json!(1);
    }
    let mut bytes = glb.clone();
    let text = serde_json::to_string(&v).unwrap();
    let mut padded = text.into_bytes();
    while padded.len() % 4 != 0 {
        padded.push(b' ');
    }
    let bin = glb[20 + json_len..].to_vec();
    bytes.truncate(12);
    bytes.extend_from_slice(&(padded.len() as u32).to_le_bytes());
    bytes.extend_from_slice(b"JSON");
    bytes.extend_from_slice(&padded);
    bytes.extend_from_slice(&bin);
    let total = bytes.len() as u32;
    bytes[8..12].copy_from_slice(&total.to_le_bytes());
    let err = import_slice(&bytes, None, "x").unwrap_err().to_string();
    assert!(err.contains("out of range"), "{err}");
}

#[test]
fn a_file_without_skin_is_a_one_joint_character() {
    // A static triangle, no skin, with a node transform that must be applied.
    let json = r#"{
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "translation": [0, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]
    }"#;
    let c = import_slice(json.as_bytes(), None, "tri").unwrap();
    assert_eq!(c.skeleton.joint_count(), 1);
    assert_eq!(c.triangle_count(), 1);
    assert!((c.vertices[1].position - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6);
    // Normals were computed (+Z for this counter-clockwise triangle).
    assert!((c.vertices[0].normal - Vec3::Z).length() < 1e-5);
}

#[test]
fn a_skinless_prop_whose_animation_moves_its_mesh_node_is_rigged() {
    // A windmill: the rotor turns on the tower (a node animation, no skin).
    let c = import_slice(common::TURNING_PROP.as_bytes(), None, "prop").unwrap();
    assert!(
        !c.warnings.iter().any(|w| w.contains("do not move it")),
        "{:?}",
        c.warnings
    );
    assert_eq!(c.clips.len(), 1);
    assert!((c.clips[0].duration_secs - 1.0).abs() < 1e-6);
    // At rest: the tower's triangle at the origin, the rotor's 1 up, the hub's 0.5 in front
    // of it; turning towards a quarter about the rotor's node, they reach towards x = -1 (the
    // clip's samples stop short of its end, which loops back to the start) and stay below 2.
    let (lo, hi) = polypostor::animation::clip_bounds(&c, None, 2);
    assert!(lo.length() < 1e-5, "{lo}");
    assert!((hi - Vec3::new(1.0, 2.0, 0.5)).length() < 1e-5, "{hi}");
    let (lo, hi) = polypostor::animation::clip_bounds(&c, Some(0), 9);
    assert!(lo.x < -0.95 && (hi.x - 1.0).abs() < 1e-4, "{lo} {hi}");
    assert!(lo.y.abs() < 1e-4 && hi.y <= 2.0 + 1e-4, "{lo} {hi}");
    // The same file without its animation stays the static one-joint character, each piece
    // placed by its nodes.
    let s = import_slice(common::still_prop().as_bytes(), None, "still").unwrap();
    assert_eq!(s.clips.len(), 0);
    assert_eq!(s.skeleton.joint_count(), 1);
    assert!((s.vertices[4].position - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6);
    assert!((s.vertices[7].position - Vec3::new(1.0, 1.0, 0.5)).length() < 1e-6);
}

#[test]
fn a_missing_external_buffer_is_named_in_the_error() {
    let dir = common::temp_dir("missing-bin");
    let c = small_character();
    let files = write_gltf(&c, &BufferStorage::External("gone.bin".into())).unwrap();
    std::fs::write(dir.join("c.gltf"), &files.json).unwrap();
    let err = polypostor::import_path(&dir.join("c.gltf")).unwrap_err();
    assert!(
        matches!(
            err,
            polypostor::ImportError::Invalid(_) | polypostor::ImportError::Buffer { .. }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("gone.bin"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// A skeleton under a mirroring node (scale −1 along x: a left-handed copy of a character)
/// turns its triangles' winding around; the importer winds them back so they face out where
/// their normals point, as in the unmirrored file (such a character was drawn inside out,
/// lit from behind: 1.4 dB against its own mesh in `compare`).
#[test]
fn a_mirrored_skeleton_keeps_its_triangles_facing_out() {
    let plain = small_character();
    let mut mirrored = plain.clone();
    let root = mirrored.skeleton.nodes.iter().position(|n| n.parent.is_none()).unwrap();
    mirrored.skeleton.nodes[root].rest.scale *= Vec3::new(-1.0, 1.0, 1.0);
    for (name, c) in [("plain", &plain), ("mirrored", &mirrored)] {
        let imported = import_slice(&write_glb(c).unwrap(), None, "x").unwrap();
        let (pos, nrm) = skin_vertices(&imported, &Pose::rest(&imported));
        let (mut out, mut total) = (0usize, 0usize);
        for t in imported.indices.chunks_exact(3) {
            let [a, b, d] = [t[0], t[1], t[2]].map(|i| pos[i as usize]);
            let face = (b - a).cross(d - a);
            if face.length() < 1e-9 {
                continue;
            }
            let n = nrm[t[0] as usize] + nrm[t[1] as usize] + nrm[t[2] as usize];
            total += 1;
            out += usize::from(face.dot(n) > 0.0);
        }
        assert!(total > 100, "{name}: {total} triangles");
        assert!(
            out as f64 > 0.95 * total as f64,
            "{name}: {out} of {total} triangles face out"
        );
    }
    // The mirror is really there: the rest pose is the plain one reflected in x.
    let (a, _) = skin_vertices(&plain, &Pose::rest(&plain));
    let m = import_slice(&write_glb(&mirrored).unwrap(), None, "x").unwrap();
    let (b, _) = skin_vertices(&m, &Pose::rest(&m));
    let max_x = |v: &[Vec3]| v.iter().map(|p| p.x).fold(f32::MIN, f32::max);
    let min_x = |v: &[Vec3]| v.iter().map(|p| p.x).fold(f32::MAX, f32::min);
    assert!((max_x(&a) + min_x(&b)).abs() < 1e-3, "{} vs {}", max_x(&a), min_x(&b));
}

/// An exporter's absolute times (every key of a clip at 2.5 s or later) would hold the first
/// pose for 2.5 s of every loop: the clip starts at its first key. Independent answer: the
/// generated character's own clips, whose keys start at 0.
#[test]
fn clips_whose_keys_all_start_late_play_from_their_first_key() {
    let c = small_character();
    let mut late = c.clone();
    for clip in &mut late.clips {
        for ch in &mut clip.channels {
            ch.times.iter_mut().for_each(|t| *t += 2.5);
        }
        clip.duration_secs += 2.5;
    }
    let back = import_slice(&write_glb(&late).unwrap(), None, "x").unwrap();
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    for (a, b) in back.clips.iter().zip(&plain.clips) {
        assert!(
            (a.duration_secs - b.duration_secs).abs() < 1e-4,
            "{} {} {}",
            a.name,
            a.duration_secs,
            b.duration_secs
        );
        for k in 0..6 {
            let t = b.duration_secs * k as f32 / 6.0;
            let (p, _) = skin_vertices(&back, &Pose::sample(&back, a, t));
            let (q, _) = skin_vertices(&plain, &Pose::sample(&plain, b, t));
            let off = p.iter().zip(&q).map(|(x, y)| (*x - *y).length()).fold(0.0f32, f32::max);
            assert!(off < 1e-4, "{} at {t} s: {off}", a.name);
        }
    }
    let said = back.warnings.iter().filter(|w| w.contains("first key")).count();
    assert_eq!(said, c.clips.len(), "{:?}", back.warnings);
    assert!(plain.warnings.iter().all(|w| !w.contains("first key")));
}
