//! Fitting one part in one view over every frame: trace each frame's mask, simplify the key
//! frame to `S` (40 vertices) and every frame to `T` (50), triangulate `S`, fit `S` onto each
//! `T` (exact DP, or the fast candidate-window mode), then simplify `S` with the deformation
//! in mind to the final polygon (20 vertices, 18 triangles).

use crate::bake::contour::{bridge_pieces, offset_outward, trace_simple};
use crate::bake::fit::{Fit, FitError, Plan};
use crate::bake::image_cost::{FOLD_COST, PartTile, SourceSamples, TargetGrid};
use crate::bake::simplify::{SimplifyOptions, is_simple, simplify};
use crate::bake::triangulate::{TriangulateError, triangulate};

/// Options of [`fit_part`]. Defaults are the paper's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartFitOptions {
    /// Vertices of the key-frame polygon S. Default value: 40.
    pub key_vertices: usize,
    /// Vertices of every frame's polygon T. Default value: 50.
    pub frame_vertices: usize,
    /// Vertices after deformation-aware simplification (at most `key_vertices`). Default
    /// value: [`DEFAULT_POLYGON_VERTICES`] (40, every fitted vertex; the paper's 20 lost
    /// 1.3–2 dB on the shared characters for a few percent of the pack: the interior warp, not
    /// only the outline, needs them. The pack also stores the polygon simplified on to half its
    /// vertices, which the crowd draws for characters small on screen; see the README's
    /// "Polygon vertices").
    pub final_vertices: usize,
    /// Exact DP over every target vertex (`O(n·m³)`) instead of the fast mode.
    /// Default value: false.
    pub exhaustive: bool,
    /// Forbid folds: a triangle may degenerate but not turn inside out (drawn, a folded
    /// triangle shows its texture mirrored over its neighbours). Off gives the paper's
    /// unconstrained objective. Default value: true.
    pub fold_free: bool,
    /// Fast mode: candidate target vertices per source vertex, nearest to where the vertex
    /// was in the previous frame. Default value: [`DEFAULT_WINDOW`].
    pub window: usize,
    /// Fast mode: a frame whose fit still costs more than this per source pixel (mean
    /// weighted colour + normal SSD) is searched again from a global coarse solution.
    /// `f64::INFINITY` turns restarts off. Default value: [`DEFAULT_RESTART_THRESHOLD`].
    pub restart_threshold: f64,
    /// Fast mode: the coarse solution of a restart is exact over every `restart_step`-th
    /// target vertex. Default value: [`DEFAULT_RESTART_STEP`].
    pub restart_step: usize,
    /// Charge target coverage the mapped polygon leaves out ([`MissedCoverage`]), so that the
    /// fit's cost and the rendered error agree. Off gives the paper's objective (source
    /// samples only). Default value: true.
    ///
    /// [`MissedCoverage`]: crate::bake::image_cost::MissedCoverage
    pub charge_missed_coverage: bool,
    /// Fast mode: target vertices either side of a vertex's carried-over contour index that
    /// join its candidates. Default value: [`HINT_RADIUS`].
    pub hint_radius: usize,
    /// Fast mode: re-centred solves after the first. Default value: [`REFINE_PASSES`].
    pub refine_passes: usize,
    /// Fast mode: sweep rounds (each frees every vertex once). Default value: [`SWEEPS`].
    pub sweeps: usize,
    /// Fast mode: target vertices a freed vertex may jump to in a sweep. Default value:
    /// [`SWEEP_FREE`].
    pub sweep_free: usize,
    /// Fast mode: a freed vertex may also move anywhere on the target contour between where
    /// its two outline neighbours map, when that run is at most this long (slides a vertex
    /// into a stretch of the target the fit leaves uncovered). 0 turns it off. Default value:
    /// [`SWEEP_GAP`].
    pub sweep_gap: usize,
    /// Fast mode: a restart's coarse solve only looks for solutions cheaper than this many
    /// times the local search's cost (prunes most of its work). Default value:
    /// [`RESTART_BOUND`].
    pub restart_bound: f64,
    /// Fast mode: finish with the exact DP bounded by the local search's cost (the exact
    /// optimum, at the price of the bounded search).
    pub finish_exact: bool,
    /// Fast mode: the refinement passes' candidates (nearest in space, and either side along
    /// the contour), smaller than the first solve's: the solution is already near. Default
    /// value: [`REFINE_WINDOW`], [`REFINE_HINT`].
    pub refine_window: usize,
    pub refine_hint: usize,
    /// Fast mode: a frame is restarted only when its cost is also above this multiple of
    /// the cheapest neighbouring frame it was seeded from (a jump in cost is the mark of a
    /// local minimum; a part that is costly in every frame is not one). 0 restarts on the
    /// threshold alone. Default value: [`RESTART_JUMP`].
    pub restart_jump: f64,
    /// Fast mode: a frame whose seeding neighbours are all stuck (their restart, or their
    /// neighbours', found nothing more than 1 % better: the local search already sits in the
    /// coarse global solution's basin) is not restarted unless its cost exceeds this multiple
    /// of theirs; it is then stuck too. 0 restarts on the threshold alone. Default value:
    /// [`RESTART_TRUST`].
    pub restart_trust: f64,
    /// After the correspondence, move each drawn vertex by fractions of a pixel where that
    /// lowers the drawn error ([`crate::bake::subpixel`]). Default value: true.
    pub subpixel: bool,
    /// Fast mode: a frame whose fitted neighbours' outlines are all farther than this from
    /// its own (mean squared distance between aligned vertices, pixels²: the first frame of
    /// another clip in a whole-character pack, a sudden move) is also seeded by the fitted
    /// frame whose outline is nearest, when that is at most half as far. `f32::INFINITY`
    /// turns it off. Default value: [`SIMILAR_SEED_PX2`].
    pub similar_seed_px2: f32,
    /// Fast mode: a frame whose outline lies this close to a fitted neighbour's (mean squared
    /// distance between aligned vertices, pixels²: a part that barely moves, as through most
    /// of an idle clip), where that neighbour's fit is good (below the restart threshold), is
    /// fitted with narrower windows ([`NEAR_STILL_WINDOW`] nearest and [`NEAR_STILL_HINT`]
    /// either side along the contour, first solve and refinement alike). 0 turns it off.
    /// Default value: [`NEAR_STILL_PX2`].
    pub near_still_px2: f32,
    /// Fast mode: the refinement passes are skipped when the first solve put every vertex
    /// at least this many target vertices inside the contour run round its carried-over
    /// index ([`PartFitOptions::hint_radius`] either side; more than that always refines).
    /// Default value: [`REFINE_MARGIN`].
    pub refine_margin: usize,
    /// Vertices added inside each part's polygon ([`crate::bake::interior`]), each moved at
    /// every frame to where it lowers the drawn error. 0: the outline's vertices alone.
    /// Default value: [`DEFAULT_INTERIOR_VERTICES`].
    pub interior_vertices: usize,
    /// A triangle under this many key-image pixels gets no interior vertex. Default value:
    /// [`DEFAULT_INTERIOR_MIN_AREA`].
    pub interior_min_area: f32,
    /// Least drawn error (squared colour error summed over pixels and frames) an interior
    /// vertex is expected to cut per byte it adds to the pack ([`interior_budget`]). 0: every
    /// part gets [`PartFitOptions::interior_vertices`]. Default value: 0; a bake prices each
    /// view's vertices by its error (`pipeline::view_fit_options`).
    pub interior_min_gain: f64,
    /// Fast mode: where the local search left a run of at least [`RESPREAD_RUN`] source
    /// vertices on one target vertex, search again from the same mapping with each such run
    /// spread evenly over the contour between its neighbours ([`respread`]); keep whichever is
    /// cheaper. Default value: true.
    pub respread: bool,
}

/// What [`PartFitOptions::interior_vertices`] interior vertices cut of a part's outline-only
/// drawn error, about (RobotExpressive, 24 views: 14–34 % per part, a quarter typical).
const INTERIOR_CUT: f64 = 0.25;

/// Interior vertices worth their bytes for a part whose outline-only polygon draws
/// `outline_error` (squared colour error summed over the block's frames) in a block of
/// `block_frames` frames: at most `most`, as many as each is expected to cut at least
/// `min_gain` times its bytes (a UV, a position per frame, two more triangles). Expected cuts
/// follow what was measured: `k` vertices cut about [`INTERIOR_CUT`] × `ln(1 + k) / ln(1 + 24)`
/// of the error (6 vertices half of what 24 do, 12 four fifths), so each added vertex is worth
/// less than the one before. `min_gain` 0 (or less) gives `most`.
pub fn interior_budget(most: usize, outline_error: f64, block_frames: usize, min_gain: f64) -> usize {
    if min_gain.is_nan() || min_gain <= 0.0 {
        return most;
    }
    let need = min_gain * (4 + 2 * block_frames + 12) as f64;
    let cut = INTERIOR_CUT * outline_error.max(0.0) / 25f64.ln();
    (0..most)
        .take_while(|&k| cut * ((k + 2) as f64 / (k + 1) as f64).ln() >= need)
        .count()
}

/// [`PartFitOptions::interior_vertices`]'s default.
pub const DEFAULT_INTERIOR_VERTICES: usize = 24;

/// [`PartFitOptions::interior_min_area`]'s default.
pub const DEFAULT_INTERIOR_MIN_AREA: f32 = 8.0;

/// Vertices of each part's polygon in the pack ([`PartFitOptions::final_vertices`]).
pub const DEFAULT_POLYGON_VERTICES: usize = 40;

/// Error per source pixel above which the fast mode restarts from a coarse global solution.
pub const DEFAULT_RESTART_THRESHOLD: f64 = 0.06;

/// Target-vertex stride of a restart's coarse exact solve.
pub const DEFAULT_RESTART_STEP: usize = 4;

/// Candidates per source vertex in the fast mode.
pub const DEFAULT_WINDOW: usize = 6;

/// [`PartFitOptions::refine_margin`]'s default: 2 left the fast mode's gap to the exact DP
/// within 0.05 points on every shared character for 10–20 % less fitting time (1: 0.1–0.2
/// points more).
pub const REFINE_MARGIN: usize = 2;

impl Default for PartFitOptions {
    fn default() -> Self {
        Self {
            key_vertices: 40,
            frame_vertices: 50,
            final_vertices: DEFAULT_POLYGON_VERTICES,
            exhaustive: false,
            fold_free: true,
            window: DEFAULT_WINDOW,
            restart_threshold: DEFAULT_RESTART_THRESHOLD,
            restart_step: DEFAULT_RESTART_STEP,
            charge_missed_coverage: true,
            hint_radius: HINT_RADIUS,
            refine_passes: REFINE_PASSES,
            sweeps: SWEEPS,
            sweep_free: SWEEP_FREE,
            sweep_gap: SWEEP_GAP,
            restart_bound: RESTART_BOUND,
            finish_exact: false,
            refine_window: REFINE_WINDOW,
            refine_hint: REFINE_HINT,
            restart_jump: RESTART_JUMP,
            restart_trust: RESTART_TRUST,
            subpixel: true,
            refine_margin: REFINE_MARGIN,
            similar_seed_px2: SIMILAR_SEED_PX2,
            near_still_px2: NEAR_STILL_PX2,
            interior_vertices: DEFAULT_INTERIOR_VERTICES,
            interior_min_area: DEFAULT_INTERIOR_MIN_AREA,
            interior_min_gain: 0.0,
            respread: true,
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PartFitError {
    #[error("the part is not visible in frame {0}")]
    Empty(usize),
    #[error("triangulation failed: {0}")]
    Triangulate(#[from] TriangulateError),
    #[error("fitting failed: {0}")]
    Fit(#[from] FitError),
}

impl PartFitError {
    /// Whether `message` (a [`PartFitError`] as text, as a part's result keeps it) says the
    /// part covers no pixel, rather than that its fit failed.
    pub fn says_empty(message: &str) -> bool {
        message.starts_with("the part is not visible")
    }
}

/// The fitted polygons of one part in one view.
#[derive(Clone, Debug, PartialEq)]
pub struct PartFit {
    pub key_frame: usize,
    /// S: the key-frame polygon (pixels of the key tile).
    pub key_polygon: Vec<[f32; 2]>,
    pub key_triangles: Vec<[usize; 3]>,
    /// T per frame.
    pub targets: Vec<Vec<[f32; 2]>>,
    /// P per frame: `mappings[f][i]` is the vertex of `targets[f]` that S vertex `i` maps to.
    pub mappings: Vec<Vec<usize>>,
    /// Fit error per frame (the DP objective).
    pub costs: Vec<f64>,
    /// The final polygon: indices of the kept S vertices, in order.
    pub kept: Vec<usize>,
    /// Final triangles, indices into `kept`.
    pub triangles: Vec<[usize; 3]>,
    /// Per frame, each S vertex's sub-pixel move off the target vertex it maps to
    /// ([`crate::bake::subpixel`]); empty where the frame has none.
    pub offsets: Vec<Vec<[f32; 2]>>,
    /// Vertices inside the polygon ([`crate::bake::interior`]), in the key image, numbered
    /// after the kept outline's (`triangles` use them).
    pub interior: Vec<[f32; 2]>,
    /// Per frame, the interior vertices' positions; empty where the frame draws them where
    /// they are in the key image.
    pub interior_at: Vec<Vec<[f32; 2]>>,
}

impl PartFit {
    /// Positions of the final polygon's vertices at frame `f` (pixels of that frame's tile).
    /// The outline's vertices first, then the interior ones.
    pub fn positions(&self, f: usize) -> Vec<[f32; 2]> {
        let moved = self.offsets.get(f).filter(|o| !o.is_empty());
        let inside = self
            .interior_at
            .get(f)
            .filter(|p| p.len() == self.interior.len())
            .unwrap_or(&self.interior);
        self.kept
            .iter()
            .map(|&i| {
                let p = self.targets[f][self.mappings[f][i]];
                match moved {
                    Some(o) => [p[0] + o[i][0], p[1] + o[i][1]],
                    None => p,
                }
            })
            .chain(inside.iter().copied())
            .collect()
    }

    /// Texture coordinates of the final polygon's vertices (pixels of the key tile): the
    /// outline's, then the interior ones.
    pub fn uvs(&self) -> Vec<[f32; 2]> {
        self.kept
            .iter()
            .map(|&i| self.key_polygon[i])
            .chain(self.interior.iter().copied())
            .collect()
    }

    /// Frame `f` draws the key image itself: the key polygon mapped onto its own vertices
    /// (the key frame, and frames showing exactly its image), nothing to move or correct.
    pub fn draws_key_image(&self, f: usize) -> bool {
        self.targets.get(f) == Some(&self.key_polygon)
            && self
                .mappings
                .get(f)
                .is_some_and(|m| m.iter().enumerate().all(|(i, &j)| i == j))
    }

    /// Vertices drawn: the kept outline's and the interior ones.
    pub fn vertex_count(&self) -> usize {
        self.kept.len() + self.interior.len()
    }

    pub fn total_cost(&self) -> f64 {
        self.costs.iter().sum()
    }
}

fn polygon_of(tile: &PartTile, vertices: usize, frame: usize) -> Result<Vec<[f32; 2]>, PartFitError> {
    let _trace = crate::bake::profile::leaf("trace");
    let contour = trace_simple(&bridge_pieces(&tile.mask()));
    if contour.len() < 3 {
        return Err(PartFitError::Empty(frame));
    }
    let kept = simplify(&contour, vertices, &SimplifyOptions::default());
    let poly: Vec<[f32; 2]> = kept.iter().map(|&i| contour[i]).collect();
    // Remove exact repeats (thin one-pixel spurs visit a pixel twice).
    let mut out: Vec<[f32; 2]> = Vec::with_capacity(poly.len());
    for p in poly {
        if !out.contains(&p) {
            out.push(p);
        }
    }
    if out.len() < 3 {
        return Err(PartFitError::Empty(frame));
    }
    // Cover the boundary pixels the contour runs through (see `offset_outward`), unless
    // growing makes the outline cross itself (two arms a pixel apart): then as traced.
    let grown = offset_outward(&out, CONTOUR_OFFSET);
    if crate::bake::simplify::is_simple(&grown) {
        return Ok(grown);
    }
    Ok(out)
}

/// How far traced outlines are grown outwards, in pixels: half a pixel takes them from the
/// boundary pixels' centres to their outer edges.
pub const CONTOUR_OFFSET: f32 = 0.5;

/// Candidate targets of each source vertex: the `window` target vertices nearest to its
/// predicted position.
fn candidates(pred: &[[f32; 2]], target: &[[f32; 2]], window: usize) -> Vec<Vec<usize>> {
    pred.iter()
        .map(|p| {
            let mut idx: Vec<usize> = (0..target.len()).collect();
            idx.sort_by(|&a, &b| {
                let da = (target[a][0] - p[0]).powi(2) + (target[a][1] - p[1]).powi(2);
                let db = (target[b][0] - p[0]).powi(2) + (target[b][1] - p[1]).powi(2);
                da.total_cmp(&db).then(a.cmp(&b))
            });
            idx.truncate(window.max(1));
            idx.sort_unstable();
            idx
        })
        .collect()
}

/// Where the fast mode expects S's vertices on a target: positions, and optionally the target
/// contour index of each (carried over from a fitted neighbouring frame).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Seed {
    pub positions: Vec<[f32; 2]>,
    pub indices: Option<Vec<usize>>,
    /// The fit cost of the neighbouring frame it came from, when known (the restart rule
    /// compares against it).
    pub cost: Option<f64>,
    /// The neighbouring frame was stuck ([`PartFitOptions::restart_trust`]).
    pub stuck: bool,
}

/// The cheapest fit cost among the seeds' neighbouring frames, where any is known.
fn best_seed_cost(seeds: &[Seed]) -> Option<f64> {
    seeds.iter().filter_map(|s| s.cost).reduce(f64::min)
}

/// Fits S onto one target. The fast mode starts from each seed (at least one) and keeps the
/// best; the exhaustive mode ignores them.
pub fn fit_frame(
    plan: &Plan,
    samples: &SourceSamples,
    target_tile: &TargetGrid,
    target: &[[f32; 2]],
    seeds: &[Seed],
    options: &PartFitOptions,
    pins: &[(usize, usize)],
) -> Result<Fit, FitError> {
    Ok(fit_frame_stuck(plan, samples, target_tile, target, seeds, options, pins)?.0)
}

/// [`fit_frame`], and whether the frame is stuck ([`PartFitOptions::restart_trust`]).
pub fn fit_frame_stuck(
    plan: &Plan,
    samples: &SourceSamples,
    target_tile: &TargetGrid,
    target: &[[f32; 2]],
    seeds: &[Seed],
    options: &PartFitOptions,
    pins: &[(usize, usize)],
) -> Result<(Fit, bool), FitError> {
    // Triangle costs evaluated (the fit's unit of work), added to [`evaluations`] at the end.
    let evaluated = std::cell::Cell::new(0u64);
    let phase = std::cell::Cell::new(0usize);
    let looked = std::cell::Cell::new(0u64);
    let by_phase: [std::cell::Cell<u64>; 4] = Default::default();
    let raw = |t: usize, p: [usize; 3], limit: f64| {
        evaluated.set(evaluated.get() + 1);
        by_phase[phase.get()].set(by_phase[phase.get()].get() + 1);
        samples.cost_indexed(t, target_tile, target, p, limit)
    };
    let pin = |cands: &mut Vec<Vec<usize>>| apply_pins(cands, pins, target.len());
    if options.exhaustive {
        let exact = exact_below(plan, samples, target_tile, target, pins, f64::INFINITY)?;
        return Ok((exact.expect("a finite optimum is below infinity"), false));
    }
    // The fast mode solves several overlapping candidate sets: remember every triangle cost
    // (exact, or a lower bound where the evaluation gave up) so no triple is sampled twice.
    let memo = std::cell::RefCell::new(CostCache::new(plan, target.len()));
    let raw_dyn: &dyn Fn(usize, [usize; 3], f64) -> f64 = &raw;
    let cost = Cached {
        samples,
        target_tile,
        target,
        memo: &memo,
        raw: raw_dyn,
        looked: &looked,
    };
    // Candidate windows: the `window` target vertices nearest in space to where the vertex is
    // expected, plus a run along the target contour around the index it is expected at
    // (the cyclic-order hint: where it went last frame, carried along the contour).
    let m = target.len() as i64;
    let hint = options.hint_radius as i64;
    let near: Vec<i64> = (-hint..=hint).collect();
    let refine_hint = options.refine_hint as i64;
    let refine_near: Vec<i64> = (-refine_hint..=refine_hint).collect();
    let windows = |at: &[[f32; 2]], centre: Option<&[usize]>, offsets: &[i64], window: usize| {
        let mut cands = candidates(at, target, window);
        if let Some(centre) = centre {
            for (c, &j) in cands.iter_mut().zip(centre) {
                c.extend(offsets.iter().map(|&d| (j as i64 + d).rem_euclid(m) as usize));
                c.sort_unstable();
                c.dedup();
            }
        }
        pin(&mut cands);
        cands
    };
    let win = options.window;
    let mut best: Option<Fit> = None;
    let mut centre: Option<Vec<usize>> = None;
    for seed in seeds {
        let fit = plan.solve_bounded(&windows(&seed.positions, seed.indices.as_deref(), &near, win), cost)?;
        if best.as_ref().is_none_or(|b| fit.cost < b.cost) {
            best = Some(fit);
            centre = seed.indices.clone();
        }
    }
    let n = plan.vertex_count();
    let mut touching = vec![Vec::new(); n];
    for t in plan.triangles() {
        for &a in t {
            for &b in t {
                if a != b && !touching[a].contains(&b) {
                    touching[a].push(b);
                }
            }
        }
    }
    let local_search = |mut best: Fit, centre: Option<&[usize]>, sweeps: usize| -> Result<Fit, FitError> {
        // A first solve whose every vertex landed well inside the run along the contour its
        // window held (at least `refine_margin` from either end) has no move at the edge of
        // its windows to follow up: re-centring would ask the same question again.
        let interior = centre.is_some_and(|c| {
            best.mapping.iter().zip(c).all(|(&j, &c)| {
                let d = (j as i64 - c as i64).rem_euclid(m);
                d.min(m - d) + options.refine_margin.min(1 << 20) as i64 <= hint
            })
        });
        // Refine: re-centre the windows on the current solution (near it in space and along
        // the target contour) and solve again; the old solution stays feasible, so the cost
        // never rises.
        for _ in 0..if interior { 0 } else { options.refine_passes } {
            let at: Vec<[f32; 2]> = best.mapping.iter().map(|&j| target[j]).collect();
            let next = plan.solve_bounded(
                &windows(&at, Some(&best.mapping), &refine_near, options.refine_window),
                cost,
            )?;
            if next.cost < best.cost - 1e-12 {
                best = next;
            } else {
                break;
            }
        }
        let outer = phase.get();
        phase.set(if outer == 2 { 2 } else { 1 });
        // Sweeps: free a set of vertices that share no triangle (each may jump to any of the
        // SWEEP_FREE target vertices nearest to it) while the rest stay within one contour
        // step of where they are; catches the far jumps (folds across a thin limb, where the
        // other side of the contour is near in space but far along it) that the windows
        // miss. Every vertex is freed once per round; the current mapping stays feasible, so
        // the cost never rises.
        for round in 0..sweeps {
            let mut covered = vec![false; n];
            let mut improved = false;
            let mut start = round * 7;
            while covered.iter().any(|c| !c) {
                let mut free = vec![false; n];
                let mut blocked = vec![false; n];
                for s in 0..n {
                    let i = (start + s) % n;
                    if !covered[i] && !blocked[i] {
                        free[i] = true;
                        covered[i] = true;
                        for &j in &touching[i] {
                            blocked[j] = true;
                        }
                    }
                }
                start += 1;
                let mut cands: Vec<Vec<usize>> = (0..n)
                    .map(|i| {
                        if free[i] {
                            let mut c = candidates(&[target[best.mapping[i]]], target, options.sweep_free).remove(0);
                            if options.sweep_gap > 0 {
                                let before = best.mapping[(i + n - 1) % n];
                                let after = best.mapping[(i + 1) % n];
                                let run = (after + target.len() - before) % target.len();
                                if run <= options.sweep_gap {
                                    c.extend((0..=run).map(|d| (before + d) % target.len()));
                                    c.sort_unstable();
                                    c.dedup();
                                }
                            }
                            c
                        } else {
                            let j = best.mapping[i] as i64;
                            let mut c: Vec<usize> = (-1..=1).map(|d| (j + d).rem_euclid(m) as usize).collect();
                            c.sort_unstable();
                            c.dedup();
                            c
                        }
                    })
                    .collect();
                pin(&mut cands);
                let next = plan.solve_bounded(&cands, cost)?;
                if next.cost < best.cost - 1e-12 {
                    best = next;
                    improved = true;
                }
            }
            if !improved {
                break;
            }
        }
        phase.set(outer);
        Ok(best)
    };
    let mut best = local_search(best.ok_or(FitError::NoSeed)?, centre.as_deref(), options.sweeps)?;
    // Collapsed runs: on a flat-coloured stretch a run of source vertices piled on one target
    // vertex costs about what it would spread out, so no single vertex's move (the windows,
    // the sweeps) finds the way out; a seed with every such run spread does.
    if options.respread
        && let Some(spread) = respread(&best.mapping, target.len())
    {
        let _respread = crate::bake::profile::leaf("respread");
        let at: Vec<[f32; 2]> = spread.iter().map(|&j| target[j]).collect();
        let start = plan.solve_bounded(&windows(&at, Some(&spread), &near, win), cost)?;
        // Re-centred solves only: sweeps after them closed no more of the gap for a tenth
        // more lookups (`fit_gap`, six views of each shared character). Its triangle costs
        // count under the windows' phase ([`evaluations_by_phase`]). A fit the spread seed
        // makes cheaper may drop under the restart threshold below and skip a restart.
        let other = local_search(start, Some(&spread), 0)?;
        if other.cost < best.cost - 1e-12 {
            crate::bake::profile::tally("respread improved");
            best = other;
        }
    }
    // Restart: where the fit stays poor (mean error per source pixel above the threshold),
    // the local search may sit in a local minimum far from the optimum (thin limbs, where a
    // better mapping slides whole runs of vertices along the contour). Solve exactly over
    // every `restart_step`-th target vertex (global, ~1/8 of the exact DP's work at step 2),
    // then search locally from there; keep whichever is cheaper.
    let neighbour = best_seed_cost(seeds);
    let mut stuck = false;
    let over = best.cost > options.restart_threshold * samples.area();
    let trusted = options.restart_trust > 0.0
        && !seeds.is_empty()
        && seeds.iter().all(|s| s.stuck)
        && neighbour.is_some_and(|c| best.cost <= options.restart_trust * c);
    if over && trusted {
        stuck = true;
    } else if over && neighbour.is_none_or(|c| best.cost > options.restart_jump * c) {
        stuck = true;
        let _restart = crate::bake::profile::leaf("restart");
        phase.set(2);
        let every: Vec<usize> = (0..target.len()).step_by(options.restart_step.max(1)).collect();
        let mut cands = vec![every; n];
        pin(&mut cands);
        // Most of these triples are never seen again: no memo.
        let coarse = if options.restart_bound.is_finite() {
            plan.solve_below(&cands, raw, options.restart_bound * best.cost)?
        } else {
            Some(plan.solve_bounded(&cands, raw)?)
        };
        let restarted = match coarse {
            Some(coarse) => {
                let at: Vec<[f32; 2]> = coarse.mapping.iter().map(|&j| target[j]).collect();
                let start = plan.solve_bounded(&windows(&at, Some(&coarse.mapping), &near, win), cost)?;
                Some(local_search(start, Some(&coarse.mapping), options.sweeps)?)
            }
            None => None,
        };
        if let Some(restarted) = restarted.filter(|r| r.cost < best.cost) {
            let much = restarted.cost < 0.99 * best.cost;
            crate::bake::profile::tally(if much {
                "restart improved >1 %"
            } else {
                "restart improved <1 %"
            });
            stuck = !much;
            best = restarted;
        }
    }
    phase.set(3);
    if options.finish_exact {
        let mut cands = vec![(0..target.len()).collect::<Vec<_>>(); n];
        pin(&mut cands);
        if let Some(better) = plan.solve_below(&cands, raw, best.cost - 1e-9)? {
            best = better;
        }
    }
    // With folds forbidden, the windows may hold no fold-free choice for some triangle (rare:
    // a part that turns over between frames). The full candidate set always has one (a
    // degenerate triangle).
    if best.cost >= FOLD_COST {
        let _rescue = crate::bake::profile::leaf("fold rescue");
        if let Some(better) = exact_below(plan, samples, target_tile, target, pins, best.cost)? {
            best = better;
        }
    }
    EVALUATIONS.fetch_add(evaluated.get(), std::sync::atomic::Ordering::Relaxed);
    THREAD_EVALUATIONS.with(|n| n.set(n.get() + evaluated.get()));
    crate::bake::profile::count(TRIANGLE_COSTS_COUNT, evaluated.get());
    LOOKUPS.fetch_add(looked.get(), std::sync::atomic::Ordering::Relaxed);
    for (a, c) in PHASES.iter().zip(&by_phase) {
        a.fetch_add(c.get(), std::sync::atomic::Ordering::Relaxed);
    }
    Ok((best, stuck))
}

/// Shortest run of source vertices on one target vertex that [`respread`] spreads. `fit_gap`,
/// six views of each shared character and the quadruped, key frame 0, against no respread:
/// 3 closed 0.15–0.2 points of the gap to the exact DP for 8 % more triangle costs and 10–25 %
/// more fitting time; 4 and 5 closed 0.1–0.2 points (RiggedSimple's bench views, at its bake's
/// key frame, +2.72 → +1.45 % with either), 4 for 25 % more cost lookups, 5 for 15 %.
pub const RESPREAD_RUN: usize = 5;

/// `mapping` (source vertex → target vertex, in order round both outlines) with every run of
/// at least [`RESPREAD_RUN`] source vertices on one target vertex `v` spread evenly, in
/// order, over the target contour between the vertex before the run and the vertex after it
/// (forwards): vertex `k` of `len` at the nearest target vertex to `(k + ½) / len` of the way,
/// measured from the vertex before (so the seed does not depend on where the target
/// contour's numbering starts; a run longer than its span lands some vertices on its ends);
/// `None` where there is no such run (or the whole polygon sits on one vertex). A seed only:
/// where two long runs meet, their spans overlap (each reaches the other's vertex), and the
/// windows round the seed sort that out. Spreading each
/// run only half-way to its neighbours' vertices (spans that never overlap) closed less of
/// the gap to the exact DP (RiggedSimple's bench views: +2.84 % against +1.45 %).
pub fn respread(mapping: &[usize], m: usize) -> Option<Vec<usize>> {
    let n = mapping.len();
    if n < RESPREAD_RUN || m == 0 {
        return None;
    }
    // Start at a vertex that begins a run (its predecessor maps elsewhere).
    let first = (0..n).find(|&i| mapping[(i + n - 1) % n] != mapping[i])?;
    let mut out = mapping.to_vec();
    let mut i = 0;
    while i < n {
        let a = (first + i) % n;
        let mut len = 1;
        while len < n && mapping[(a + len) % n] == mapping[a] {
            len += 1;
        }
        if len >= RESPREAD_RUN {
            let (v, before) = (mapping[a], mapping[(a + n - 1) % n]);
            // Forward distance from the previous run's vertex to v, and from v to the next's.
            let width = ((v + m - before) % m + (mapping[(a + len) % n] + m - v) % m) as f64;
            for k in 0..len {
                let off = ((k as f64 + 0.5) * width / len as f64).round() as usize;
                out[(a + k) % n] = (before + off) % m;
            }
        }
        i += len;
    }
    (out != mapping).then_some(out)
}

/// The fast mode's triangle cost: folds priced directly, everything else through the cost
/// cache (evaluated on first use with `raw`). Its look-up is compiled into the solves' inner
/// loop ([`crate::bake::fitting::fit::TriangleCost`]); the rare paths stay out of line.
#[derive(Clone, Copy)]
struct Cached<'a> {
    samples: &'a SourceSamples,
    target_tile: &'a TargetGrid,
    target: &'a [[f32; 2]],
    memo: &'a std::cell::RefCell<CostCache>,
    raw: &'a dyn Fn(usize, [usize; 3], f64) -> f64,
    looked: &'a std::cell::Cell<u64>,
}

impl crate::bake::fitting::fit::TriangleCost for Cached<'_> {
    #[inline(always)]
    fn cost(&self, t: usize, p: [usize; 3], limit: f64) -> f64 {
        self.looked.set(self.looked.get() + 1);
        // A fold costs a table lookup and a few multiplications: cheaper than the memo.
        if self.samples.folds(t, self.target, p) {
            return fold(self.samples, self.target_tile, self.target, t, p, limit);
        }
        let mut memo = self.memo.borrow_mut();
        let cell = memo.cell(t, p);
        // Stored values >= 0 are exact; a negative value -b records "cost >= b"; NaN: not
        // evaluated yet.
        let v = *cell;
        if v >= 0.0 {
            return v;
        }
        if -v >= limit {
            return f64::INFINITY;
        }
        miss(cell, self.raw, t, p, limit)
    }
}

/// A fold's cost, out of line (see [`Cached`]).
#[inline(never)]
fn fold(samples: &SourceSamples, tile: &TargetGrid, target: &[[f32; 2]], t: usize, p: [usize; 3], limit: f64) -> f64 {
    samples.cost_indexed(t, tile, target, p, limit)
}

/// A cost the fast mode's cache does not hold yet: evaluated and stored in `cell` (exact, or
/// `-limit` as a lower bound where the evaluation gave up). Kept out of line, so the look-up
/// that finds its cost in the cache (most of them) stays a short function.
#[inline(never)]
fn miss(cell: &mut f64, raw: &dyn Fn(usize, [usize; 3], f64) -> f64, t: usize, p: [usize; 3], limit: f64) -> f64 {
    let c = raw(t, p, limit);
    if c.is_finite() {
        *cell = c;
    } else if limit > 0.0 {
        *cell = -limit;
    }
    c
}

/// The fast mode's cache of triangle costs: for each triangle and targets of the two corners
/// a solve holds fixed, a row with one value per target vertex of the corner it varies
/// ([`Plan::inner_corners`]), so the costs a solve asks for one after the other sit side by
/// side (a hash map scattered them: a cache miss a lookup). Rows are made on first use.
struct CostCache {
    m: usize,
    inner: Vec<usize>,
    /// Row start in `values` per (triangle, outer corner target, outer corner target), or
    /// `u32::MAX`; a hash map instead where that table would be large.
    rows: RowIndex,
    values: Vec<f64>,
}

enum RowIndex {
    Dense(Vec<u32>),
    Sparse(rustc_hash::FxHashMap<usize, u32>),
}

/// Most entries of a dense row index (4 bytes each).
const DENSE_ROWS: usize = 1 << 20;

impl CostCache {
    fn new(plan: &Plan, m: usize) -> Self {
        let triangles = plan.triangles().len();
        let n = triangles.saturating_mul(m).saturating_mul(m);
        Self {
            m,
            inner: plan.inner_corners(),
            rows: if n <= DENSE_ROWS {
                RowIndex::Dense(vec![u32::MAX; n])
            } else {
                RowIndex::Sparse(Default::default())
            },
            values: Vec::with_capacity(1 << 14),
        }
    }

    /// The cached value of triangle `t` mapped onto `p` (NaN where not evaluated yet).
    #[inline(always)]
    fn cell(&mut self, t: usize, p: [usize; 3]) -> &mut f64 {
        let (inner, a, b) = match self.inner[t] {
            0 => (p[0], p[1], p[2]),
            1 => (p[1], p[0], p[2]),
            _ => (p[2], p[0], p[1]),
        };
        let key = (t * self.m + a) * self.m + b;
        let m = self.m;
        let values = &mut self.values;
        let mut fresh = || {
            let start = values.len();
            values.resize(start + m, f64::NAN);
            start as u32
        };
        let start = match &mut self.rows {
            RowIndex::Dense(index) => {
                if index[key] == u32::MAX {
                    index[key] = fresh();
                }
                index[key]
            }
            RowIndex::Sparse(index) => *index.entry(key).or_insert_with(fresh),
        };
        &mut self.values[start as usize + inner]
    }
}

static EVALUATIONS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
static LOOKUPS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Triangle costs the fast mode's DP solves asked for (evaluated, folded or found in the
/// memo).
pub fn lookups() -> u64 {
    LOOKUPS.load(std::sync::atomic::Ordering::Relaxed)
}

static PHASES: [std::sync::atomic::AtomicU64; 4] = [const { std::sync::atomic::AtomicU64::new(0) }; 4];

/// [`evaluations`] by phase: windows (with the respread seed's solves), sweeps, restart, exact
/// finish.
pub fn evaluations_by_phase() -> [u64; 4] {
    PHASES.each_ref().map(|a| a.load(std::sync::atomic::Ordering::Relaxed))
}

/// Triangle costs the fast mode has evaluated in this process so far (memo hits not
/// counted): the fitting's unit of work, steadier than timings on a shared machine.
pub fn evaluations() -> u64 {
    EVALUATIONS.load(std::sync::atomic::Ordering::Relaxed)
}

thread_local! {
    static THREAD_EVALUATIONS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// [`evaluations`] made on this thread (a fit runs on the thread that asks for it), so a
/// caller can measure one fit's work while other threads fit too.
pub fn evaluations_on_this_thread() -> u64 {
    THREAD_EVALUATIONS.with(|n| n.get())
}

/// Pinned correspondences `(S vertex, T vertex)` leave that vertex one candidate; pins out of
/// range are ignored.
fn apply_pins(cands: &mut [Vec<usize>], pins: &[(usize, usize)], m: usize) {
    for &(i, j) in pins {
        if i < cands.len() && j < m {
            cands[i] = vec![j];
        }
    }
}

/// The exact DP over every target vertex (pins kept), looking only for mappings cheaper than
/// `upper`; that bound prunes part of the search.
fn exact_below(
    plan: &Plan,
    samples: &SourceSamples,
    target_tile: &TargetGrid,
    target: &[[f32; 2]],
    pins: &[(usize, usize)],
    upper: f64,
) -> Result<Option<Fit>, FitError> {
    let mut cands = vec![(0..target.len()).collect::<Vec<_>>(); plan.vertex_count()];
    apply_pins(&mut cands, pins, target.len());
    let cost = |t: usize, p: [usize; 3], limit: f64| samples.cost_indexed(t, target_tile, target, p, limit);
    plan.solve_below(&cands, cost, upper)
}

/// The target grid of a frame: with the missed-coverage table when the objective charges it.
pub fn target_grid(tile: &PartTile, outline: &[[f32; 2]], options: &PartFitOptions) -> TargetGrid {
    if options.charge_missed_coverage {
        TargetGrid::with_outline(tile, outline)
    } else {
        TargetGrid::new(tile)
    }
}

/// Fast mode: how far along the target contour around the carried-over index to look.
pub const HINT_RADIUS: usize = 5;

/// The cyclic shift `d` that best aligns polygon `a` onto `b` (`a[j]` near `b[j + d]`), for
/// polygons with the same vertex count; `None` otherwise.
pub fn cyclic_shift(a: &[[f32; 2]], b: &[[f32; 2]]) -> Option<usize> {
    aligned(a, b).map(|(d, _)| d)
}

/// [`cyclic_shift`] and the mean squared distance (pixels²) between the vertices it pairs:
/// how far apart two frames' outlines are.
pub fn aligned(a: &[[f32; 2]], b: &[[f32; 2]]) -> Option<(usize, f32)> {
    let m = b.len();
    if a.len() != m || m == 0 {
        return None;
    }
    (0..m)
        .map(|d| {
            let e: f32 = (0..m)
                .map(|j| (a[j][0] - b[(j + d) % m][0]).powi(2) + (a[j][1] - b[(j + d) % m][1]).powi(2))
                .sum();
            (d, e / m as f32)
        })
        .min_by(|x, y| x.1.total_cmp(&y.1))
}

/// The mean of a polygon's vertices.
fn centre(t: &[[f32; 2]]) -> [f32; 2] {
    let n = t.len().max(1) as f32;
    let s = t.iter().fold([0.0f32; 2], |a, p| [a[0] + p[0], a[1] + p[1]]);
    [s[0] / n, s[1] / n]
}

/// Of the frames `allowed` accepts, the one whose outline is nearest frame `f`'s
/// ([`aligned`]; the first in frame order among equals) and its alignment. The distance
/// between two frames' vertex means is a lower bound of their outlines' (the mean of the
/// paired differences is the difference of the means), so frames are tried nearest mean
/// first and the search stops where that bound passes the best so far: the same answer as
/// trying every frame, at the cost of a few on a long pack.
fn nearest_outline(
    targets: &[Vec<[f32; 2]>],
    centres: &[[f32; 2]],
    f: usize,
    allowed: impl Fn(usize) -> bool,
) -> Option<(usize, (usize, f32))> {
    let c = centres[f];
    let mut order: Vec<(f32, usize)> = (0..targets.len())
        .filter(|&h| allowed(h))
        .map(|h| ((centres[h][0] - c[0]).powi(2) + (centres[h][1] - c[1]).powi(2), h))
        .collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let mut best: Option<(usize, (usize, f32))> = None;
    for (bound, h) in order {
        // Rounding: the bound is computed apart from the distance, so leave it a margin.
        if best.is_some_and(|b| bound > b.1.1 * 1.001 + 1e-3) {
            break;
        }
        if let Some(a) = aligned(&targets[h], &targets[f]) {
            let better = best.is_none_or(|b| a.1 < b.1.1 || (a.1 == b.1.1 && h < b.0));
            if better {
                best = Some((h, a));
            }
        }
    }
    best
}

/// The name of the bake profile's count of triangle costs the fast mode evaluated
/// (`report.json`'s `cpu_counts`): the fit's unit of work, steadier than timings.
pub const TRIANGLE_COSTS_COUNT: &str = "triangle costs evaluated";

/// [`PartFitOptions::similar_seed_px2`]'s default (8 pixels apart on average). In a
/// four-clip bake of the default character (24 views) it seeded 930 of 11,000 part-frames,
/// cost 2 % more triangle costs and raised the mean PSNR by 0.04 dB (Walk and Run +0.11);
/// single-clip bakes were unchanged (default +0.001 dB, CesiumMan 0).
pub const SIMILAR_SEED_PX2: f32 = 64.0;

/// [`PartFitOptions::near_still_px2`]'s default (3 pixels apart on average). In `fit_gap`'s
/// views (137, every 20th or 23rd, key frame 0) it cut the triangle costs of the default
/// character's Idle by 28 % and Wave by 25 %, RiggedFigure's by 15 %, the rest by 2–8 %,
/// for 0.0–0.12 points more gap to the exact DP. A contour run of 3 either side saved
/// about twice as much but took RiggedFigure's gap over 2 %.
pub const NEAR_STILL_PX2: f32 = 9.0;

/// Nearest target vertices per source vertex for a near-still frame
/// ([`PartFitOptions::near_still_px2`]; [`DEFAULT_WINDOW`] otherwise).
pub const NEAR_STILL_WINDOW: usize = 4;

/// Contour run either side of the carried-over index for a near-still frame
/// ([`HINT_RADIUS`] otherwise).
pub const NEAR_STILL_HINT: usize = 4;

/// Fast mode: restart only above this multiple of the seeding neighbour's cost.
pub const RESTART_JUMP: f64 = 0.0;

/// See [`PartFitOptions::restart_trust`].
pub const RESTART_TRUST: f64 = 1.0;

/// Fast mode: candidates nearest in space in a refinement pass.
pub const REFINE_WINDOW: usize = DEFAULT_WINDOW;

/// Fast mode: contour run either side in a refinement pass.
pub const REFINE_HINT: usize = HINT_RADIUS;

/// Refinement passes of the fast mode.
pub const REFINE_PASSES: usize = 2;

/// Fast mode: sweep rounds after the refinement passes (each frees every vertex once).
pub const SWEEPS: usize = 1;

/// Fast mode: target vertices (nearest in space) a freed vertex may jump to in a sweep.
pub const SWEEP_FREE: usize = 16;

/// Fast mode: longest contour run between a freed vertex's neighbours it may move into.
pub const SWEEP_GAP: usize = 24;

/// Fast mode: a restart's coarse solve looks below this multiple of the local cost.
pub const RESTART_BOUND: f64 = f64::INFINITY;

/// Removes S vertices one at a time, each time the one whose removal moves the outline least,
/// averaged over every frame, until `target` remain; keeps the key polygon simple.
pub fn deformation_aware_simplify(fit_positions: &[Vec<[f32; 2]>], key: &[[f32; 2]], target: usize) -> Vec<usize> {
    let n = key.len();
    let mut kept: Vec<usize> = (0..n).collect();
    let f64s = |p: [f32; 2]| [p[0] as f64, p[1] as f64];
    let dist = |p: [f32; 2], a: [f32; 2], b: [f32; 2]| {
        crate::bake::simplify::dist_to_segment(f64s(p), f64s(a), f64s(b)) as f32
    };
    while kept.len() > target.max(3) {
        let m = kept.len();
        let mut best: Option<(f32, usize)> = None;
        for k in 0..m {
            let (a, i, b) = (kept[(k + m - 1) % m], kept[k], kept[(k + 1) % m]);
            let err: f32 = fit_positions
                .iter()
                .map(|pos| dist(pos[i], pos[a], pos[b]))
                .sum::<f32>()
                / fit_positions.len().max(1) as f32;
            if best.is_some_and(|(e, _)| e <= err) {
                continue;
            }
            let trial: Vec<[f32; 2]> = kept
                .iter()
                .enumerate()
                .filter(|(q, _)| *q != k)
                .map(|(_, &v)| key[v])
                .collect();
            if is_simple(&trial) {
                best = Some((err, k));
            }
        }
        let Some((_, k)) = best else { break };
        kept.remove(k);
    }
    kept
}

/// The coarse level of a fitted polygon, for characters small on screen: the same
/// deformation-aware simplification continued to half the vertices (`uvs`: the polygon's
/// vertices in the key image; `positions`: per frame the polygon's positions), triangulated;
/// triangles as vertex numbers of the full polygon. Because the simplification is greedy and
/// removes one vertex at a time, its vertices are exactly those the polygon would have kept at
/// that size. Empty when the polygon has under 8 vertices or its half cannot be triangulated.
pub fn coarse_triangles(positions: &[Vec<[f32; 2]>], uvs: &[[f32; 2]]) -> Vec<[usize; 3]> {
    let n = uvs.len();
    if n < 8 {
        return Vec::new();
    }
    let kept = deformation_aware_simplify(positions, uvs, n / 2);
    let poly: Vec<[f32; 2]> = kept.iter().map(|&i| uvs[i]).collect();
    triangulate(&poly)
        .map(|t| t.iter().map(|tri| tri.map(|i| kept[i])).collect())
        .unwrap_or_default()
}

/// The coarse level of `fit` ([`coarse_triangles`] of its outline; `positions`: per frame the
/// drawn vertices, outline first). A polygon with interior vertices always has one (its
/// outline alone where it is too small to thin), so the run time never thins a vertex list
/// holding interior vertices as though it were an outline.
pub fn coarse_of(fit: &PartFit, positions: &[Vec<[f32; 2]>]) -> Vec<[usize; 3]> {
    let n = fit.kept.len();
    let outline: Vec<Vec<[f32; 2]>> = positions.iter().map(|p| p[..n.min(p.len())].to_vec()).collect();
    let uvs = fit.uvs();
    let coarse = coarse_triangles(&outline, &uvs[..n]);
    if coarse.is_empty() && !fit.interior.is_empty() {
        return triangulate(&uvs[..n]).unwrap_or_default();
    }
    coarse
}

/// The order in which the fast mode fits the frames of a looping clip, each with the
/// neighbouring frames already fitted (its seeds): the key frame first, then out from it both
/// ways, alternately, so no chain is longer than half the loop and the last frame, opposite
/// the key, starts from both its neighbours.
pub fn walk_order(frames: usize, key: usize) -> Vec<(usize, Vec<usize>)> {
    let mut fitted = vec![false; frames];
    let mut out = Vec::with_capacity(frames);
    for s in 0..frames {
        let f = if s % 2 == 1 {
            (key + s.div_ceil(2)) % frames
        } else {
            (key + frames - s / 2) % frames
        };
        let mut neighbours: Vec<usize> = [(f + frames - 1) % frames, (f + 1) % frames]
            .into_iter()
            .filter(|&g| fitted[g])
            .collect();
        neighbours.dedup();
        fitted[f] = true;
        out.push((f, neighbours));
    }
    out
}

/// Fits one part over all frames of one view. `tiles[f]` is the part at frame `f`; `key` is
/// the key frame. `pins[f]` are pinned correspondences `(S vertex, T vertex)` at frame `f`.
pub fn fit_part(
    tiles: &[PartTile],
    key: usize,
    options: &PartFitOptions,
    pins: &[Vec<(usize, usize)>],
) -> Result<PartFit, PartFitError> {
    let targets = frame_targets(tiles, options)?;
    Ok(fit_part_span(tiles, &targets, key, options, pins, None)?.0)
}

/// Every frame's target polygon T ([`PartFitOptions::frame_vertices`] vertices): the same
/// whichever key frame is fitted onto it, so a part's several keys share them.
///
/// A frame where the part shows nothing (a limb or a weapon scaled to nothing, as game rigs
/// hide them) gets [`VANISHED_SIZE`]-pixel triangle at the middle of the nearest frame's
/// outline where it shows: the fit maps the polygon onto that point, which draws no pixel,
/// and in between the part shrinks to it as the real one does. Only a part that shows in no
/// frame at all is an error.
pub fn frame_targets(tiles: &[PartTile], options: &PartFitOptions) -> Result<Vec<Vec<[f32; 2]>>, PartFitError> {
    let traced: Vec<Result<Vec<[f32; 2]>, PartFitError>> = (0..tiles.len())
        .map(|f| polygon_of(&tiles[f], options.frame_vertices, f))
        .collect();
    let n = traced.len();
    let shown: Vec<usize> = (0..n).filter(|&f| traced[f].is_ok()).collect();
    if shown.is_empty() {
        return traced.into_iter().collect();
    }
    (0..n)
        .map(|f| match &traced[f] {
            Ok(p) => Ok(p.clone()),
            Err(_) => {
                // The nearest frame that shows the part, round the loop.
                let near = *shown
                    .iter()
                    .min_by_key(|&&g| {
                        let d = g.abs_diff(f);
                        (d.min(n - d), g)
                    })
                    .expect("some frame shows the part");
                let c = centre(traced[near].as_ref().expect("a frame that shows the part"));
                let h = VANISHED_SIZE;
                Ok(vec![[c[0] - h, c[1] - h], [c[0] + h, c[1] - h], [c[0], c[1] + h]])
            }
        })
        .collect()
}

/// Half the size, in pixels, of the point a part that shows nothing in a frame is mapped onto
/// ([`frame_targets`]): too small to cover any pixel centre's neighbourhood.
pub const VANISHED_SIZE: f32 = 0.01;

/// The frames a key's fit covers: `count` frames from `start`, round the loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    pub start: usize,
    pub count: usize,
}

impl Span {
    pub fn contains(&self, f: usize, frames: usize) -> bool {
        frames > 0 && (f + frames - self.start % frames) % frames < self.count
    }

    /// The frame of the span nearest to `f` round the loop (`f` itself inside it).
    pub fn nearest(&self, f: usize, frames: usize) -> usize {
        if self.contains(f, frames) || self.count == 0 {
            return f;
        }
        let end = (self.start + self.count - 1) % frames;
        let after_end = (f + frames - end) % frames;
        let before_start = (self.start + frames - f) % frames;
        if after_end <= before_start {
            end
        } else {
            self.start % frames
        }
    }
}

/// Fits one part from key frame `key` onto the targets, walking the loop out from the key
/// both ways alternately (each frame seeded by its fitted neighbours, as [`walk_order`]).
/// With `losing`, each direction stops after the first frame `losing(frame, cost)` calls a
/// loss (that frame is kept, so every frame the key wins has both neighbours fitted): a
/// second key is fitted only as far as it can win. Frames outside the returned span take the
/// nearest fitted frame's polygon and cost `f64::INFINITY`. Without `losing` every frame is
/// fitted, in exactly [`walk_order`]'s order.
pub fn fit_part_span(
    tiles: &[PartTile],
    targets: &[Vec<[f32; 2]>],
    key: usize,
    options: &PartFitOptions,
    pins: &[Vec<(usize, usize)>],
    losing: Option<&dyn Fn(usize, f64) -> bool>,
) -> Result<(PartFit, Span), PartFitError> {
    let frames = tiles.len();
    let key_polygon = targets_key_polygon(tiles, key, options, pins)?;
    let key_triangles = triangulate(&key_polygon)?;
    let plan = Plan::new(key_polygon.len(), &key_triangles)?;
    let samples = SourceSamples::new(&tiles[key], &key_polygon, &key_triangles, options.fold_free);
    let mut mappings = vec![Vec::new(); frames];
    let mut costs = vec![f64::INFINITY; frames];
    let mut fitted = vec![false; frames];
    let centres: Vec<[f32; 2]> = targets.iter().map(|t| centre(t)).collect();
    // Frames whose restart (or their neighbours') found nothing better.
    let stuck = std::cell::RefCell::new(vec![false; frames]);
    // Distance walked each way; `None` once that way has stopped.
    let (mut forward, mut backward) = (Some(0usize), Some(0usize));
    // The windows for a frame near still (see `fit_one`).
    let narrowed = PartFitOptions {
        window: options.window.min(NEAR_STILL_WINDOW),
        hint_radius: options.hint_radius.min(NEAR_STILL_HINT),
        refine_window: options.refine_window.min(NEAR_STILL_WINDOW),
        refine_hint: options.refine_hint.min(NEAR_STILL_HINT),
        ..*options
    };
    let fit_one = |f: usize,
                   fitted: &mut Vec<bool>,
                   mappings: &mut Vec<Vec<usize>>,
                   costs: &[f64]|
     -> Result<f64, PartFitError> {
        let mut neighbours: Vec<usize> = [(f + frames - 1) % frames, (f + 1) % frames]
            .into_iter()
            .filter(|&g| fitted[g])
            .collect();
        neighbours.dedup();
        let none = Vec::new();
        let pins_f = pins.get(f).unwrap_or(&none);
        // A part that holds still between two frames (same image, same pins) gets the fitted
        // neighbour's answer: the same problem, already solved.
        if let Some(&same) = neighbours.iter().find(|&&g| {
            tiles[g].px == tiles[f].px && targets[g] == targets[f] && pins.get(g).unwrap_or(&none) == pins_f
        }) {
            crate::bake::profile::tally("frames still");
            fitted[f] = true;
            let was_stuck = stuck.borrow()[same];
            stuck.borrow_mut()[f] = was_stuck;
            mappings[f] = mappings[same].clone();
            return Ok(costs[same]);
        }
        // A seed holds a fitted neighbour's positions and its contour indices carried over
        // by the cyclic shift between the two target polygons.
        crate::bake::profile::tally("frames fitted");
        let mut sources: Vec<(usize, Option<(usize, f32)>)> = neighbours
            .iter()
            .map(|&g| (g, aligned(&targets[g], &targets[f])))
            .collect();
        // Where every fitted neighbour's outline is far from this frame's (the first frame of
        // another clip in a whole-character pack, a sudden move), the fitted frame whose
        // outline is nearest seeds it too, when it is at most half as far.
        let near = sources
            .iter()
            .filter_map(|s| s.1.map(|a| a.1))
            .fold(f32::INFINITY, f32::min);
        if !neighbours.is_empty() && near > options.similar_seed_px2 {
            let similar = nearest_outline(targets, &centres, f, |h| fitted[h] && !neighbours.contains(&h))
                .filter(|(_, a)| a.1 < 0.5 * near);
            if let Some((h, a)) = similar {
                crate::bake::profile::tally("frames seeded by a similar frame");
                sources.push((h, Some(a)));
            }
        }
        let mut seeds: Vec<Seed> = sources
            .into_iter()
            .map(|(pf, shift)| Seed {
                cost: costs[pf].is_finite().then_some(costs[pf]),
                stuck: stuck.borrow()[pf],
                positions: mappings[pf].iter().map(|&j| targets[pf][j]).collect(),
                indices: shift.map(|(shift, _)| {
                    let m = targets[f].len();
                    mappings[pf].iter().map(|&j| (j + shift) % m).collect()
                }),
            })
            .collect();
        seeds.dedup();
        if seeds.is_empty() {
            seeds.push(Seed {
                positions: key_polygon.clone(),
                indices: None,
                cost: None,
                stuck: false,
            });
        }
        // A part that barely moved since a fitted neighbour: its answer lies near the
        // neighbour's, so narrower windows (`narrowed`) find it for a fraction of the work.
        // Only where the neighbour's fit is good (below the restart threshold): on a poorly
        // fitted part the wide windows are what finds the way out.
        let good = best_seed_cost(&seeds).is_some_and(|c| c <= options.restart_threshold * samples.area());
        let still = near <= options.near_still_px2 && good;
        if still {
            crate::bake::profile::tally("frames near still");
        }
        let (fit, is_stuck) = fit_frame_stuck(
            &plan,
            &samples,
            &target_grid(&tiles[f], &targets[f], options),
            &targets[f],
            &seeds,
            if still { &narrowed } else { options },
            pins_f,
        )?;
        fitted[f] = true;
        stuck.borrow_mut()[f] = is_stuck;
        mappings[f] = fit.mapping;
        Ok(fit.cost)
    };
    costs[key] = fit_one(key, &mut fitted, &mut mappings, &costs)?;
    let mut turn_forward = true;
    let mut done = 1;
    while done < frames && (forward.is_some() || backward.is_some()) {
        let go_forward = forward.is_some() && (turn_forward || backward.is_none());
        turn_forward = !turn_forward;
        let (way, f) = if go_forward {
            let d = forward.as_mut().expect("forward walk");
            *d += 1;
            (true, (key + *d) % frames)
        } else {
            let d = backward.as_mut().expect("backward walk");
            *d += 1;
            (false, (key + frames - *d % frames) % frames)
        };
        if fitted[f] {
            break;
        }
        let cost = fit_one(f, &mut fitted, &mut mappings, &costs)?;
        costs[f] = cost;
        done += 1;
        if losing.is_some_and(|l| l(f, cost)) {
            if way {
                forward = None;
            } else {
                backward = None;
            }
        }
    }
    let back = (1..frames).take_while(|&d| fitted[(key + frames - d) % frames]).count();
    let span = if done == frames {
        Span {
            start: 0,
            count: frames,
        }
    } else {
        Span {
            start: (key + frames - back) % frames,
            count: done,
        }
    };
    let mut targets: Vec<Vec<[f32; 2]>> = targets.to_vec();
    // The key frame, and every frame showing exactly its image, draws the key image itself:
    // S onto its own vertices (the identity, cost 0). Fitted onto T, the frame's outline
    // simplified to more vertices and grown on its own, each S vertex lands on a T vertex up
    // to a pixel away, which bends straight edges and cuts or spikes corners of the very
    // image the texture is (a static prop was drawn that way in every frame). Pinned frames
    // keep the artist's correspondences.
    // (A frame's target is traced from its image, so the same image has the same target.)
    let identity: Vec<usize> = (0..key_polygon.len()).collect();
    for f in 0..frames {
        let unpinned = pins.get(f).is_none_or(|p| p.is_empty());
        if fitted[f] && unpinned && (f == key || tiles[f].px == tiles[key].px) {
            targets[f] = key_polygon.clone();
            mappings[f] = identity.clone();
            costs[f] = 0.0;
        }
    }
    // Frames outside the span borrow the nearest fitted frame's mapping and polygon.
    for f in 0..frames {
        if !fitted[f] {
            let g = span.nearest(f, frames);
            mappings[f] = mappings[g].clone();
            targets[f] = targets[g].clone();
        }
    }
    let positions: Vec<Vec<[f32; 2]>> = (0..frames)
        .filter(|&f| fitted[f])
        .map(|f| mappings[f].iter().map(|&j| targets[f][j]).collect())
        .collect();
    let _simplify = crate::bake::profile::leaf("simplify");
    let kept = deformation_aware_simplify(&positions, &key_polygon, options.final_vertices);
    let final_poly: Vec<[f32; 2]> = kept.iter().map(|&i| key_polygon[i]).collect();
    let triangles = triangulate(&final_poly)?;
    let mut fit = PartFit {
        key_frame: key,
        key_polygon,
        key_triangles,
        targets,
        mappings,
        costs,
        kept,
        triangles,
        offsets: vec![Vec::new(); frames],
        interior: Vec::new(),
        interior_at: vec![Vec::new(); frames],
    };
    if options.subpixel {
        let _subpixel = crate::bake::profile::leaf("subpixel");
        subpixel_frames(&mut fit, tiles, &fitted, pins, &|f| span.nearest(f, frames));
    }
    if options.interior_vertices > 0 {
        let _interior = crate::bake::profile::leaf("interior vertices");
        interior_frames(&mut fit, tiles, &fitted, options, &|f| span.nearest(f, frames));
    }
    Ok((fit, span))
}

/// Adds interior vertices to `fit`, a fit over `span` made without them (a key chosen on its
/// outline alone, [`crate::bake::keys::choose`]): what [`fit_part_span`] does at its end.
pub fn add_interior_vertices(fit: &mut PartFit, tiles: &[PartTile], span: Span, options: &PartFitOptions) {
    if options.interior_vertices == 0 || !fit.interior.is_empty() {
        return;
    }
    let frames = tiles.len();
    let fitted: Vec<bool> = (0..frames).map(|f| span.contains(f, frames)).collect();
    let _interior = crate::bake::profile::leaf("interior vertices");
    interior_frames(fit, tiles, &fitted, options, &|f| span.nearest(f, frames));
}

/// An interior vertex's moves: a face slides across a turning head by several pixels
/// between key and frame, so the steps start at 4 pixels, with up to 2 passes at each length
/// (24 views, 24 interior vertices: 1 pass 0.1–0.3 dB less for about half the time, 3 passes
/// 0.03–0.08 dB more for 20 % more).
const INTERIOR_STEPS: crate::bake::subpixel::Steps<'static> = crate::bake::subpixel::Steps {
    lengths: &[4.0, 2.0, 1.0, 0.5, 0.25],
    passes: 2,
};

/// Adds up to [`PartFitOptions::interior_vertices`] vertices inside the polygon
/// ([`crate::bake::interior`]; as many as [`interior_budget`] finds worth their bytes from the
/// outline-only drawing's error) and moves them, at every fitted frame not drawing the key
/// image itself, wherever that lowers the drawn error. Two meshes are tried: the outline's
/// triangles split at the added vertices (each frame then starts from exactly the
/// outline-only drawing, so it can only gain) and the same made Delaunay by flips (better
/// shaped triangles that let a vertex travel further, but whose start differs from the
/// outline-only drawing); the one whose frames nearest the key (a third of them) end with
/// less error is kept and moved at the rest ([`InteriorWalk`]). Frames
/// outside the fitted span borrow the positions of the frame whose mapping they borrow
/// (`nearest`).
fn interior_frames(
    fit: &mut PartFit,
    tiles: &[PartTile],
    fitted: &[bool],
    options: &PartFitOptions,
    nearest: &dyn Fn(usize) -> usize,
) {
    let frames = tiles.len();
    let outline = fit.uvs();
    let drawn: Vec<Option<Vec<[f32; 2]>>> = (0..frames)
        .map(|f| (fitted[f] && !fit.draws_key_image(f)).then(|| fit.positions(f)))
        .collect();
    // A part drawing its key image in every frame (a prop at rest) has nothing to move.
    if drawn.iter().all(Option::is_none) {
        return;
    }
    let refiner = crate::bake::subpixel::Refiner::new(&tiles[fit.key_frame]);
    let truths: Vec<Option<crate::bake::raster::Canvas>> = drawn
        .iter()
        .zip(tiles)
        .map(|(d, t)| d.as_ref().map(|_| crate::bake::raster::tile_canvas(t)))
        .collect();
    // How many the part's error pays for, from its outline-only drawing's error.
    let unmoved = crate::bake::subpixel::Steps {
        lengths: &[],
        passes: 0,
    };
    let outline_error: f64 = drawn
        .iter()
        .zip(&truths)
        .filter_map(|(d, t)| {
            let (d, t) = (d.as_ref()?, t.as_ref()?);
            Some(
                refiner
                    .refine_steps(&mut d.clone(), &outline, &fit.triangles, t, &[], unmoved)
                    .0,
            )
        })
        .sum();
    let block_frames = fitted.iter().filter(|&&f| f).count();
    let most = interior_budget(
        options.interior_vertices,
        outline_error,
        block_frames,
        options.interior_min_gain,
    );
    if most == 0 {
        return;
    }
    let meshes = [false, true].map(|flip| {
        crate::bake::interior::add_interior(&outline, &fit.triangles, &drawn, most, options.interior_min_area, flip)
    });
    // Both meshes walk the frames nearest the key (a third of the drawn frames, both ways);
    // only the one with less error there walks the rest (both all the way: 0.00–0.02 dB more
    // for half again the time).
    let walk: Vec<(usize, Vec<usize>)> = walk_order(frames, fit.key_frame)
        .into_iter()
        .filter(|(f, _)| drawn[*f].is_some())
        .collect();
    let trial = walk.len().div_ceil(INTERIOR_TRIAL_SHARE).min(walk.len());
    let mut walks: Vec<InteriorWalk<'_>> = meshes
        .iter()
        .filter(|m| !m.uvs.is_empty())
        .map(|m| InteriorWalk::new(fit, m, &drawn, &truths, &refiner))
        .collect();
    for w in &mut walks {
        for (f, neighbours) in &walk[..trial] {
            w.visit(*f, neighbours);
        }
    }
    let best = walks.into_iter().min_by(|a, b| a.total.total_cmp(&b.total));
    // (No walk: neither mesh could take a vertex.)
    let Some(mut best) = best else { return };
    for (f, neighbours) in &walk[trial..] {
        best.visit(*f, neighbours);
    }
    let (mesh, mut interior_at) = (best.mesh.clone(), best.interior_at);
    for f in 0..frames {
        if !fitted[f] {
            interior_at[f] = interior_at[nearest(f)].clone();
        }
    }
    fit.interior = mesh.uvs;
    fit.triangles = mesh.triangles;
    fit.interior_at = interior_at;
}

/// Drawn frames (out of every three) on which both interior meshes are tried before one is
/// kept ([`interior_frames`]).
const INTERIOR_TRIAL_SHARE: usize = 3;

/// The interior vertices of `mesh` moved frame by frame ([`InteriorWalk::visit`], in the
/// order of [`walk_order`]) at the frames `drawn` gives outline positions for (`truths`: those
/// frames' renders), with the drawn error summed over the frames visited. Each frame starts
/// from a visited neighbouring frame's moves carried over (a slide that builds up over frames;
/// from both neighbours where two were visited, keeping whichever ends with less error), else
/// (or where that folds a triangle) from where the outline's warp puts the vertices.
struct InteriorWalk<'a> {
    mesh: &'a crate::bake::interior::Interior,
    drawn: &'a [Option<Vec<[f32; 2]>>],
    truths: &'a [Option<crate::bake::raster::Canvas>],
    refiner: &'a crate::bake::subpixel::Refiner<'a>,
    /// Outline vertices (numbered first).
    n: usize,
    uvs: Vec<[f32; 2]>,
    fixed: Vec<bool>,
    sign: Vec<f32>,
    /// Each visited frame's interior moves off the outline's warp.
    moves: Vec<Option<Vec<[f32; 2]>>>,
    interior_at: Vec<Vec<[f32; 2]>>,
    total: f64,
}

impl<'a> InteriorWalk<'a> {
    fn new(
        fit: &PartFit,
        mesh: &'a crate::bake::interior::Interior,
        drawn: &'a [Option<Vec<[f32; 2]>>],
        truths: &'a [Option<crate::bake::raster::Canvas>],
        refiner: &'a crate::bake::subpixel::Refiner<'a>,
    ) -> Self {
        use crate::bake::interior::area2;
        let frames = drawn.len();
        let n = fit.kept.len();
        let uvs: Vec<[f32; 2]> = fit.uvs().into_iter().chain(mesh.uvs.iter().copied()).collect();
        let fixed: Vec<bool> = (0..uvs.len()).map(|i| i < n).collect();
        let sign: Vec<f32> = mesh
            .triangles
            .iter()
            .map(|t| area2(uvs[t[0]], uvs[t[1]], uvs[t[2]]).signum())
            .collect();
        Self {
            mesh,
            drawn,
            truths,
            refiner,
            n,
            uvs,
            fixed,
            sign,
            moves: vec![None; frames],
            interior_at: vec![Vec::new(); frames],
            total: 0.0,
        }
    }

    fn fold_free(&self, p: &[[f32; 2]]) -> bool {
        use crate::bake::interior::area2;
        self.mesh
            .triangles
            .iter()
            .zip(&self.sign)
            .all(|(t, s)| area2(p[t[0]], p[t[1]], p[t[2]]) * s >= 0.0)
    }

    /// Moves the interior vertices at frame `f`, whose visited neighbours are `neighbours`.
    fn visit(&mut self, f: usize, neighbours: &[usize]) {
        let (Some(outline), Some(truth)) = (&self.drawn[f], &self.truths[f]) else {
            return;
        };
        let n = self.n;
        let mut warped = outline.clone();
        warped.extend_from_slice(&self.mesh.positions[f]);
        let mut starts: Vec<Vec<[f32; 2]>> = Vec::new();
        for &g in neighbours {
            if let Some(m) = &self.moves[g] {
                let mut carried = warped.clone();
                for (k, d) in m.iter().enumerate() {
                    carried[n + k] = [carried[n + k][0] + d[0], carried[n + k][1] + d[1]];
                }
                if self.fold_free(&carried) && !starts.contains(&carried) {
                    starts.push(carried);
                }
            }
        }
        if starts.is_empty() {
            starts.push(warped.clone());
        }
        let (best, error) = starts
            .into_iter()
            .map(|mut pos| {
                let (_, after) = self.refiner.refine_steps(
                    &mut pos,
                    &self.uvs,
                    &self.mesh.triangles,
                    truth,
                    &self.fixed,
                    INTERIOR_STEPS,
                );
                (pos, after)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((warped.clone(), 0.0));
        self.total += error;
        self.moves[f] = Some(
            (n..best.len())
                .map(|i| [best[i][0] - warped[i][0], best[i][1] - warped[i][1]])
                .collect(),
        );
        self.interior_at[f] = best[n..].to_vec();
    }
}

/// Moves every fitted frame's drawn vertices by fractions of a pixel where that lowers the
/// drawn error ([`crate::bake::subpixel`]); frames drawing the key image itself stay, pinned
/// vertices stay, and frames outside the fitted span borrow the moves of the frame whose
/// mapping they borrow (`nearest`).
fn subpixel_frames(
    fit: &mut PartFit,
    tiles: &[PartTile],
    fitted: &[bool],
    pins: &[Vec<(usize, usize)>],
    nearest: &dyn Fn(usize) -> usize,
) {
    let uvs = fit.uvs();
    let refiner = crate::bake::subpixel::Refiner::new(&tiles[fit.key_frame]);
    for f in 0..tiles.len() {
        if !fitted[f] || fit.draws_key_image(f) {
            continue;
        }
        let pinned: Vec<usize> = pins.get(f).map_or(Vec::new(), |p| p.iter().map(|&(s, _)| s).collect());
        let fixed: Vec<bool> = fit.kept.iter().map(|i| pinned.contains(i)).collect();
        let before = fit.positions(f);
        let mut pos = before.clone();
        let truth = crate::bake::raster::tile_canvas(&tiles[f]);
        refiner.refine(&mut pos, &uvs, &fit.triangles, &truth, &fixed);
        let mut offsets = vec![[0.0f32; 2]; fit.key_polygon.len()];
        for (k, &i) in fit.kept.iter().enumerate() {
            offsets[i] = [pos[k][0] - before[k][0], pos[k][1] - before[k][1]];
        }
        fit.offsets[f] = offsets;
    }
    for f in 0..tiles.len() {
        if !fitted[f] {
            fit.offsets[f] = fit.offsets[nearest(f)].clone();
        }
    }
}

/// S: the key frame's outline simplified to [`PartFitOptions::key_vertices`].
///
/// A part whose every frame shows the key image itself (a prop at rest, a clip of one frame;
/// no pins) draws that image in every frame, through the identity: its polygon need not
/// follow the outline, only hold it, and the alpha test draws the outline exactly
/// ([`crate::bake::contour::covering_polygon`]). Any other part keeps the traced outline,
/// which the other frames' fits need (a covering key polygon took them 2–5 dB down).
fn targets_key_polygon(
    tiles: &[PartTile],
    key: usize,
    options: &PartFitOptions,
    pins: &[Vec<(usize, usize)>],
) -> Result<Vec<[f32; 2]>, PartFitError> {
    let still = tiles.iter().all(|t| t.px == tiles[key].px) && pins.iter().all(|p| p.is_empty());
    if still {
        let most = options.key_vertices.min(options.final_vertices);
        if let Some(cover) = crate::bake::contour::covering_polygon(&tiles[key].mask(), most) {
            return Ok(cover);
        }
    }
    polygon_of(&tiles[key], options.key_vertices, key)
}

#[cfg(test)]
mod tests {
    /// Only "covers nothing" reads as empty from a part's kept message (the report leaves such
    /// views out of its means; a failed fit must stay in them).
    #[test]
    fn only_an_empty_part_says_empty() {
        use super::PartFitError;
        use crate::bake::fit::FitError;
        assert!(PartFitError::says_empty(&PartFitError::Empty(3).to_string()));
        for e in [
            PartFitError::Fit(FitError::EmptyTarget),
            PartFitError::Fit(FitError::NoTriangles),
        ] {
            assert!(!PartFitError::says_empty(&e.to_string()), "{e}");
        }
    }
    use super::*;

    /// `aligned` finds the shift that pairs a polygon's vertices with a re-numbered,
    /// translated copy's, and their mean squared distance: brute force over every shift.
    #[test]
    fn aligned_outlines_pair_the_renumbered_copy() {
        let a: Vec<[f32; 2]> = (0..23)
            .map(|j| {
                let t = j as f32 * std::f32::consts::TAU / 23.0;
                [30.0 + (12.0 + (3 * j % 7) as f32) * t.cos(), 40.0 + 9.0 * t.sin()]
            })
            .collect();
        let m = a.len();
        for k in [0usize, 1, 7, 22] {
            let b: Vec<[f32; 2]> = (0..m)
                .map(|j| {
                    let p = a[(j + m - k) % m];
                    [p[0] + 3.0, p[1] - 4.0]
                })
                .collect();
            let (d, e) = aligned(&a, &b).unwrap();
            assert_eq!(d, k);
            assert!((e - 25.0).abs() < 1e-3, "{e}");
            assert_eq!(cyclic_shift(&a, &b), Some(k));
        }
        assert_eq!(aligned(&a, &a[1..]), None);
    }

    /// `nearest_outline` (frames tried nearest vertex mean first, stopping at the bound)
    /// gives what trying every frame gives: brute force over random outlines.
    #[test]
    fn nearest_outline_is_the_brute_force_nearest() {
        let mut seed = 11u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as f32 / (1u64 << 31) as f32
        };
        for _ in 0..50 {
            let frames = 40;
            let targets: Vec<Vec<[f32; 2]>> = (0..frames)
                .map(|_| {
                    let (cx, cy, r) = (40.0 + 30.0 * rnd(), 40.0 + 30.0 * rnd(), 5.0 + 20.0 * rnd());
                    let m = if rnd() < 0.1 { 12 } else { 16 };
                    (0..m)
                        .map(|j| {
                            let t = j as f32 * std::f32::consts::TAU / m as f32;
                            [cx + r * t.cos() + rnd(), cy + 0.7 * r * t.sin() + rnd()]
                        })
                        .collect()
                })
                .collect();
            let centres: Vec<[f32; 2]> = targets.iter().map(|t| centre(t)).collect();
            let f = (rnd() * frames as f32) as usize % frames;
            let allowed = |h: usize| h != f && h % 3 != 1;
            let brute = (0..frames)
                .filter(|&h| allowed(h))
                .filter_map(|h| aligned(&targets[h], &targets[f]).map(|a| (h, a)))
                .min_by(|x, y| x.1.1.total_cmp(&y.1.1).then(x.0.cmp(&y.0)));
            assert_eq!(nearest_outline(&targets, &centres, f, allowed), brute);
        }
    }

    /// A part that shows nothing in some frames (a limb scaled to nothing) is fitted in the
    /// others and mapped onto a point where it vanishes, drawing no pixel there; a part that
    /// shows in no frame is still an error.
    #[test]
    fn a_part_that_vanishes_for_some_frames_draws_nothing_there() {
        let mut t = tiles(6);
        for f in [2, 3] {
            t[f].px.iter_mut().for_each(|p| *p = [0.0; 7]);
        }
        let options = PartFitOptions::default();
        let targets = frame_targets(&t, &options).unwrap();
        // Frame 2's point sits at the middle of frame 1's outline (the nearest that shows).
        let mid = centre;
        let (a, b) = (mid(&targets[2]), mid(&targets[1]));
        assert!((a[0] - b[0]).abs() < 0.02 && (a[1] - b[1]).abs() < 0.02, "{a:?} {b:?}");
        assert!(
            targets[3]
                .iter()
                .all(|q| (q[0] - mid(&targets[4])[0]).abs() <= 2.0 * VANISHED_SIZE)
        );
        let fit = fit_part(&t, 0, &options, &[]).unwrap();
        for f in 0..6 {
            let drawn = crate::bake::keys::draw_part(&fit, &t[0], f, t[f].size);
            let covered = drawn.px.iter().filter(|p| p[3] > 0.5).count();
            if f == 2 || f == 3 {
                assert_eq!(covered, 0, "frame {f}");
            } else {
                let truth = t[f].px.iter().filter(|p| p[6] > 0.5).count();
                assert!(covered as f64 > 0.8 * truth as f64, "frame {f}: {covered} of {truth}");
            }
        }
        let mut none = tiles(3);
        none.iter_mut()
            .for_each(|t| t.px.iter_mut().for_each(|p| *p = [0.0; 7]));
        assert!(matches!(fit_part(&none, 0, &options, &[]), Err(PartFitError::Empty(_))));
    }

    /// A textured ellipse that moves and stretches over frames.
    fn tiles(frames: usize) -> Vec<PartTile> {
        moving_tiles(frames, 1.0)
    }

    /// [`tiles`] moving `step` times as fast: 2 `step` pixels a frame to the right, growing
    /// `step` pixels a frame wide and shrinking half that high.
    fn moving_tiles(frames: usize, step: f32) -> Vec<PartTile> {
        (0..frames)
            .map(|f| {
                let size = 64u32;
                let f = f as f32 * step;
                let (cx, cy) = (28.0 + f * 2.0, 32.0);
                let (rx, ry) = (14.0 + f, 20.0 - f * 0.5);
                let px = (0..size * size)
                    .map(|i| {
                        let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
                        let (u, v) = ((x - cx) / rx, (y - cy) / ry);
                        if u * u + v * v < 1.0 {
                            // Texture attached to the shape: stripes along v.
                            let stripe = if ((v + 1.0) * 4.0).floor() as i32 % 2 == 0 {
                                1.0
                            } else {
                                0.2
                            };
                            [
                                stripe,
                                v * 0.5 + 0.5,
                                u * 0.5 + 0.5,
                                0.5 + 0.3 * u,
                                0.5 + 0.3 * v,
                                1.0,
                                1.0,
                            ]
                        } else {
                            [0.0; 7]
                        }
                    })
                    .collect();
                PartTile { size, px }
            })
            .collect()
    }

    #[test]
    fn the_key_frame_and_frames_showing_its_image_draw_the_key_polygon_itself() {
        // Moving: the key frame is S onto itself (the key image, unwarped), the others fitted.
        let t = tiles(5);
        let o = PartFitOptions::default();
        for key in [0, 2] {
            let fit = fit_part(&t, key, &o, &[]).unwrap();
            assert_eq!(fit.positions(key)[..fit.kept.len()], fit.key_polygon[..], "key {key}");
            assert_eq!(fit.positions(key), fit.uvs(), "key {key}");
            assert_eq!(fit.costs[key], 0.0);
            // The identity really costs nothing under the fit's own objective.
            let samples = SourceSamples::new(&t[key], &fit.key_polygon, &fit.key_triangles, o.fold_free);
            let grid = target_grid(&t[key], &fit.targets[key], &o);
            let identity: f64 = fit
                .key_triangles
                .iter()
                .enumerate()
                .map(|(k, tri)| samples.cost_indexed(k, &grid, &fit.targets[key], *tri, f64::INFINITY))
                .sum();
            assert!(identity < 1e-9, "{identity}");
            for f in (0..5).filter(|&f| f != key) {
                assert!(
                    fit.costs[f] > 0.0 && fit.positions(f)[..fit.kept.len()] != fit.key_polygon[..],
                    "frame {f}"
                );
            }
        }
        // Still (a static prop): every frame is the key image.
        let still = vec![t[1].clone(); 4];
        let fit = fit_part(&still, 1, &o, &[]).unwrap();
        for f in 0..4 {
            assert_eq!(fit.positions(f), fit.key_polygon, "frame {f}");
            assert_eq!(fit.costs[f], 0.0);
        }
        // A pin at the key frame keeps the artist's correspondence (fitted onto T).
        let j = 3;
        let mut pins = vec![Vec::new(); 5];
        pins[0] = vec![(0, j)];
        let pinned = fit_part(&t, 0, &o, &pins).unwrap();
        assert_eq!(pinned.mappings[0][0], j);
        assert_eq!(pinned.positions(0)[0], pinned.targets[0][j]);
    }

    #[test]
    fn fits_a_moving_textured_shape_and_simplifies_to_the_final_size() {
        let t = tiles(5);
        // By default every fitted vertex is kept.
        let full = fit_part(&t, 0, &PartFitOptions::default(), &[]).unwrap();
        assert_eq!(full.kept.len(), full.key_polygon.len().min(DEFAULT_POLYGON_VERTICES));
        let options = PartFitOptions {
            final_vertices: 20,
            ..Default::default()
        };
        let fit = fit_part(&t, 0, &options, &[]).unwrap();
        assert!(
            fit.key_polygon.len() <= 42 && fit.key_polygon.len() >= 30,
            "{}",
            fit.key_polygon.len()
        );
        assert_eq!(fit.kept.len(), 20);
        assert_eq!(fit.triangles.len(), 18 + 2 * fit.interior.len());
        assert!(is_simple(&fit.uvs()[..20]));
        // Mapped vertices follow the motion: their centroid moves right by ~2 px per frame.
        let centroid = |p: &[[f32; 2]]| p.iter().map(|q| q[0]).sum::<f32>() / p.len() as f32;
        let c0 = centroid(&fit.positions(0));
        let c4 = centroid(&fit.positions(4));
        assert!((c4 - c0 - 8.0).abs() < 3.0, "{c0} -> {c4}");
    }

    /// The exact DP's fit from key frame 0.
    fn exact_fit(t: &[PartTile]) -> PartFit {
        let exhaustive = PartFitOptions {
            exhaustive: true,
            ..Default::default()
        };
        fit_part(t, 0, &exhaustive, &[]).unwrap()
    }

    #[test]
    fn fast_mode_is_within_two_percent_of_the_exact_dp() {
        let t = tiles(4);
        let fast = fit_part(&t, 0, &PartFitOptions::default(), &[]).unwrap();
        let exact = exact_fit(&t);
        assert!(exact.total_cost() <= fast.total_cost() + 1e-9);
        assert!(
            fast.total_cost() <= exact.total_cost() * 1.02 + 1e-6,
            "fast {} exact {}",
            fast.total_cost(),
            exact.total_cost()
        );
    }

    /// Frames where a part barely moves are fitted with narrower windows: less work for
    /// nearly the same answer; a part that moves far is fitted as before.
    #[test]
    fn near_still_frames_cost_less_work_for_nearly_the_same_fit() {
        let fit = |tiles: &[PartTile], options: &PartFitOptions| {
            let before = evaluations_on_this_thread();
            let total = fit_part(tiles, 0, options, &[]).unwrap().total_cost();
            (total, evaluations_on_this_thread() - before)
        };
        let off = PartFitOptions {
            near_still_px2: 0.0,
            ..Default::default()
        };
        let on = PartFitOptions::default();
        assert!(on.near_still_px2 > 0.0, "narrowing is on by default");
        // A third of a pixel a frame: every frame is near its neighbour.
        let slow = moving_tiles(8, 0.15);
        let (full_cost, full_work) = fit(&slow, &off);
        let (narrow_cost, narrow_work) = fit(&slow, &on);
        assert!(
            (narrow_work as f64) < 0.85 * full_work as f64,
            "narrow windows evaluated {narrow_work} triangle costs, full ones {full_work}"
        );
        assert!(
            narrow_cost <= 1.01 * full_cost + 1e-6,
            "narrow windows cost {narrow_cost}, full ones {full_cost}"
        );
        // Four pixels a frame is never near: the same fit and the same work either way.
        let fast = moving_tiles(4, 2.0);
        assert_eq!(fit(&fast, &off), fit(&fast, &on));
    }

    #[test]
    fn skipping_the_refinement_of_interior_solves_stays_near_always_refining() {
        let t = tiles(8);
        let with = |refine_margin: usize| {
            fit_part(
                &t,
                0,
                &PartFitOptions {
                    refine_margin,
                    ..Default::default()
                },
                &[],
            )
            .unwrap()
            .total_cost()
        };
        let (skipping, always, never_interior) = (with(REFINE_MARGIN), with(usize::MAX), with(HINT_RADIUS + 1));
        // A margin wider than the hint never finds a solve interior: the same as always.
        assert_eq!(always, never_interior);
        let exact = exact_fit(&t).total_cost();
        assert!(exact <= skipping + 1e-9 && exact <= always + 1e-9);
        assert!(skipping <= always * 1.005 + 1e-6, "skipping {skipping} always {always}");
    }

    /// Signed area of the target triangle of `t` under `mapping`, times the source's sign.
    fn oriented_areas(fit: &PartFit, f: usize) -> Vec<f32> {
        let area = |p: [[f32; 2]; 3]| {
            0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]))
        };
        fit.key_triangles
            .iter()
            .map(|t| {
                let s = area(t.map(|i| fit.key_polygon[i])).signum();
                s * area(t.map(|i| fit.targets[f][fit.mappings[f][i]]))
            })
            .collect()
    }

    /// A disc whose outline holds still while its striped texture slides across it (a head
    /// turning in place), moved `shift` pixels a frame.
    fn sliding_tiles(frames: usize, shift: f32) -> Vec<PartTile> {
        let size = 64u32;
        (0..frames)
            .map(|f| {
                let px = (0..size * size)
                    .map(|i| {
                        let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
                        let (u, v) = ((x - 32.0) / 22.0, (y - 32.0) / 22.0);
                        if u * u + v * v < 1.0 {
                            let s = x - f as f32 * shift;
                            let stripe = 0.5 + 0.4 * (s * 0.35).sin();
                            [stripe, 0.3, 1.0 - stripe, 0.5 + 0.3 * u, 0.5 + 0.3 * v, 1.0, 1.0]
                        } else {
                            [0.0; 7]
                        }
                    })
                    .collect();
                PartTile { size, px }
            })
            .collect()
    }

    /// Every drawn triangle's signed area at frame `f`, turned by its orientation in the key
    /// image (negative: folded).
    fn drawn_areas(fit: &PartFit, f: usize) -> Vec<f32> {
        let area = |p: [[f32; 2]; 3]| {
            0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]))
        };
        let (uv, pos) = (fit.uvs(), fit.positions(f));
        fit.triangles
            .iter()
            .map(|t| area(t.map(|i| uv[i])).signum() * area(t.map(|i| pos[i])))
            .collect()
    }

    /// The budget against its closed form: the `k`-th vertex pays while
    /// `cut · ln((k + 1) / k) ≥ need`, that is while `k ≤ 1 / (e^(need / cut) − 1)`.
    #[test]
    fn the_interior_budget_is_the_closed_form_count() {
        for error in [0.0, 0.5, 3.0, 41.0, 917.0, 1e6] {
            for frames in [1usize, 10, 34, 200] {
                for gain in [0.003, 0.03, 0.3] {
                    let got = interior_budget(24, error, frames, gain);
                    let need = gain * (16 + 2 * frames) as f64;
                    let cut = INTERIOR_CUT * error / 25f64.ln();
                    let closed = if cut <= 0.0 {
                        0
                    } else {
                        (1.0 / ((need / cut).exp() - 1.0)).floor().min(24.0) as usize
                    };
                    assert_eq!(got, closed, "error {error}, {frames} frames, gain {gain}");
                }
            }
        }
        // Scaling the error and the price together changes nothing.
        assert_eq!(
            interior_budget(24, 300.0, 10, 0.03),
            interior_budget(24, 1200.0, 10, 0.12)
        );
        // More error never buys fewer; more frames (more bytes each) never more.
        let mut last = 0;
        for e in [1.0, 10.0, 100.0, 1000.0, 10000.0] {
            let n = interior_budget(24, e, 10, 0.03);
            assert!(n >= last && n <= 24);
            last = n;
        }
        assert!(last > 0);
        assert!(interior_budget(24, 500.0, 100, 0.03) <= interior_budget(24, 500.0, 10, 0.03));
        // Off: every part gets the most.
        assert_eq!(interior_budget(12, 0.0, 10, 0.0), 12);
        assert_eq!(interior_budget(12, 0.0, 10, f64::NAN), 12);
    }

    /// The budget is what the fit uses: none when no vertex could pay, some where the texture
    /// slides.
    #[test]
    fn a_part_gets_interior_vertices_only_where_their_bytes_pay() {
        let t = sliding_tiles(4, 2.0);
        let fit = |interior_vertices: usize, interior_min_gain: f64| {
            let options = PartFitOptions {
                interior_vertices,
                interior_min_gain,
                ..Default::default()
            };
            fit_part(&t, 0, &options, &[]).unwrap()
        };
        let priced_out = fit(8, 1e9);
        assert!(priced_out.interior.is_empty());
        assert_eq!(priced_out.triangles, fit(0, 0.0).triangles);
        let paid = fit(8, 0.03);
        assert!(
            !paid.interior.is_empty() && paid.interior.len() <= 8,
            "{}",
            paid.interior.len()
        );
    }

    /// Where the texture slides inside an outline that holds still, interior vertices follow
    /// it: the drawn error falls well below the outline-only polygon's, no drawn triangle
    /// turns over, the key frame draws the key image itself, and the vertex numbering is
    /// the outline's then the interior ones'.
    #[test]
    fn interior_vertices_follow_a_texture_sliding_inside_a_still_outline() {
        let t = sliding_tiles(4, 2.0);
        let drawn_error = |fit: &PartFit| -> f64 {
            (0..t.len())
                .map(|f| {
                    let c = crate::bake::inspect::part_canvas(fit, &t[0], f as f32);
                    crate::bake::keys::sse(&c, &crate::bake::raster::tile_canvas(&t[f]))
                })
                .sum()
        };
        let outline_only = fit_part(
            &t,
            0,
            &PartFitOptions {
                interior_vertices: 0,
                ..Default::default()
            },
            &[],
        )
        .unwrap();
        assert!(outline_only.interior.is_empty());
        let options = PartFitOptions {
            interior_vertices: 8,
            ..Default::default()
        };
        let fit = fit_part(&t, 0, &options, &[]).unwrap();
        assert_eq!(fit.interior.len(), 8);
        assert_eq!(fit.vertex_count(), fit.kept.len() + 8);
        assert_eq!(fit.triangles.len(), fit.kept.len() - 2 + 16);
        assert_eq!(fit.uvs()[..fit.kept.len()], outline_only.uvs()[..]);
        assert_eq!(fit.positions(0), fit.uvs(), "the key frame draws the key image itself");
        for f in 0..t.len() {
            let areas = drawn_areas(&fit, f);
            assert!(areas.iter().all(|&a| a >= -1e-4), "frame {f}: {areas:?}");
            assert_eq!(
                fit.positions(f)[..fit.kept.len()],
                outline_only.positions(f)[..],
                "frame {f}"
            );
        }
        for f in 0..t.len() {
            let e = |fit: &PartFit| {
                let c = crate::bake::inspect::part_canvas(fit, &t[0], f as f32);
                crate::bake::keys::sse(&c, &crate::bake::raster::tile_canvas(&t[f]))
            };
            eprintln!("frame {f}: {} vs {}", e(&fit), e(&outline_only));
        }
        let (with, without) = (drawn_error(&fit), drawn_error(&outline_only));
        // (The outline's own fit already slides much of the texture round the disc.)
        assert!(
            with < 0.99 * without,
            "interior vertices: {with}, outline alone: {without}"
        );
        // The coarse level is the outline's alone.
        let positions: Vec<Vec<[f32; 2]>> = (0..t.len()).map(|f| fit.positions(f)).collect();
        let coarse = coarse_of(&fit, &positions);
        assert!(!coarse.is_empty());
        assert!(coarse.iter().flatten().all(|&i| i < fit.kept.len()));
    }

    #[test]
    fn the_coarse_level_keeps_half_the_vertices_and_covers_their_polygon() {
        // A 40-vertex wobbly ring whose every frame stretches it: the coarse level has 20 of
        // its vertices, in outline order, and its triangles tile the polygon through them
        // (areas add up, none inside out); the simplification's rule applied from scratch to
        // 20 keeps the same vertices (the levels nest).
        let n = 40;
        let ring: Vec<[f32; 2]> = (0..n)
            .map(|k| {
                let a = k as f32 * std::f32::consts::TAU / n as f32;
                let r = 20.0 + 3.0 * (5.0 * a).sin();
                [50.0 + r * a.cos(), 50.0 + r * a.sin()]
            })
            .collect();
        let frames: Vec<Vec<[f32; 2]>> = (0..6)
            .map(|f| ring.iter().map(|p| [p[0] * (1.0 + 0.05 * f as f32), p[1]]).collect())
            .collect();
        let tris = coarse_triangles(&frames, &ring);
        let mut used: Vec<usize> = tris.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), n / 2);
        assert_eq!(used, deformation_aware_simplify(&frames, &ring, n / 2));
        let area = |t: [[f32; 2]; 3]| {
            ((t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[2][0] - t[0][0]) * (t[1][1] - t[0][1])) / 2.0
        };
        let poly: Vec<[f32; 2]> = used.iter().map(|&i| ring[i]).collect();
        let shoelace: f32 = (0..poly.len())
            .map(|k| {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                (a[0] * b[1] - b[0] * a[1]) / 2.0
            })
            .sum();
        let areas: Vec<f32> = tris.iter().map(|t| area(t.map(|i| ring[i]))).collect();
        assert!(areas.iter().all(|a| a.signum() == shoelace.signum()), "{areas:?}");
        let sum: f32 = areas.iter().sum();
        assert!((sum - shoelace).abs() < 1e-3 * shoelace.abs(), "{sum} vs {shoelace}");
        assert_eq!(tris.len(), n / 2 - 2);
        // Too small to thin.
        assert!(
            coarse_triangles(
                &frames[..1].iter().map(|f| f[..7].to_vec()).collect::<Vec<_>>(),
                &ring[..7]
            )
            .is_empty()
        );
    }

    #[test]
    fn fold_free_fits_never_turn_a_triangle_inside_out_and_cost_what_they_report() {
        let t = tiles(4);
        for exhaustive in [false, true] {
            let options = PartFitOptions {
                exhaustive,
                ..Default::default()
            };
            let fit = fit_part(&t, 0, &options, &[]).unwrap();
            let samples = SourceSamples::new(&t[0], &fit.key_polygon, &fit.key_triangles, true);
            for f in 0..4 {
                let areas = oriented_areas(&fit, f);
                assert!(
                    areas.iter().all(|&a| a >= -crate::bake::image_cost::FOLD_TOLERANCE),
                    "frame {f}: {areas:?}"
                );
                // The reported cost is the sum of the triangle costs of the mapping.
                let grid = target_grid(&t[f], &fit.targets[f], &options);
                let sum: f64 = (0..fit.key_triangles.len())
                    .map(|k| {
                        samples.cost_indexed(
                            k,
                            &grid,
                            &fit.targets[f],
                            fit.key_triangles[k].map(|i| fit.mappings[f][i]),
                            f64::INFINITY,
                        )
                    })
                    .sum();
                assert!(
                    (sum - fit.costs[f]).abs() <= 1e-6 * sum.max(1.0),
                    "{sum} vs {}",
                    fit.costs[f]
                );
            }
        }
    }

    #[test]
    fn the_exact_dp_is_exact_for_the_objective_with_missed_coverage() {
        // Small polygons of a real moving shape, so every mapping can be tried: S with 5
        // vertices onto T with 7 (7⁵ mappings), the full objective (source SSD + folds +
        // missed target coverage) against brute force, for several frames.
        let t = tiles(4);
        for fold_free in [true, false] {
            let key = polygon_of(&t[0], 5, 0).unwrap();
            let tris = triangulate(&key).unwrap();
            let plan = Plan::new(key.len(), &tris).unwrap();
            let samples = SourceSamples::new(&t[0], &key, &tris, fold_free);
            for f in 1..4 {
                let target = polygon_of(&t[f], 7, f).unwrap();
                let grid = TargetGrid::with_outline(&t[f], &target);
                let exact = exact_below(&plan, &samples, &grid, &target, &[], f64::INFINITY)
                    .unwrap()
                    .unwrap();
                let bf = crate::bake::fit::brute_force(key.len(), &tris, target.len(), |k, p| {
                    samples.cost_indexed(k, &grid, &target, p, f64::INFINITY)
                });
                assert!(
                    (exact.cost - bf.cost).abs() <= 1e-9 * bf.cost.max(1.0),
                    "frame {f}: DP {} vs brute force {}",
                    exact.cost,
                    bf.cost
                );
                // The missed-coverage term is really in play: the plain objective's optimum
                // costs less under the plain objective than under the full one.
                let plain = TargetGrid::new(&t[f]);
                let bf_plain = crate::bake::fit::brute_force(key.len(), &tris, target.len(), |k, p| {
                    samples.cost_indexed(k, &plain, &target, p, f64::INFINITY)
                });
                assert!(bf_plain.cost < bf.cost, "{} vs {}", bf_plain.cost, bf.cost);
            }
        }
    }

    /// Six [`tiles`], fitted from key frame 0, with the plan and source samples a frame's
    /// solve needs.
    fn fitted_tiles() -> (Vec<PartTile>, PartFit, Plan, SourceSamples) {
        let t = tiles(6);
        let fit = fit_part(&t, 0, &PartFitOptions::default(), &[]).unwrap();
        let plan = Plan::new(fit.key_polygon.len(), &fit.key_triangles).unwrap();
        let samples = SourceSamples::new(&t[0], &fit.key_polygon, &fit.key_triangles, true);
        (t, fit, plan, samples)
    }

    #[test]
    fn restarts_never_raise_a_frame_cost_nor_beat_the_exact_dp() {
        let (t, fit, plan, samples) = fitted_tiles();
        let seed = [Seed {
            positions: fit.key_polygon.clone(),
            indices: None,
            cost: None,
            stuck: false,
        }];
        for f in 1..t.len() {
            let grid = TargetGrid::new(&t[f]);
            let solve = |restart_threshold: f64, exhaustive: bool| {
                let o = PartFitOptions {
                    restart_threshold,
                    exhaustive,
                    ..Default::default()
                };
                fit_frame(&plan, &samples, &grid, &fit.targets[f], &seed, &o, &[]).unwrap()
            };
            let (plain, always, exact) = (solve(f64::INFINITY, false), solve(0.0, false), solve(0.0, true));
            assert!(always.cost <= plain.cost + 1e-9, "frame {f}");
            assert!(exact.cost <= always.cost + 1e-9, "frame {f}");
        }
    }

    #[test]
    fn respreading_spreads_every_long_run_evenly_and_leaves_the_rest() {
        // Random mappings that wind once round an 8-vertex target (as a fit does), with runs
        // wrapping the source's index 0 too. Each vertex is checked on its own: its run found
        // by walking both ways; outside a long run it keeps its target, inside one it sits
        // at the middle of its equal share of the span from the vertex before the run to the
        // one after. Numbering the target or the source from elsewhere changes nothing.
        let m = 8;
        let mut rng = 7u64;
        let mut next = |k: usize| {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((rng >> 33) as usize) % k
        };
        let mut spread = 0;
        for _ in 0..3000 {
            let n = 3 + next(20);
            let mut values: Vec<usize> = (0..n).map(|_| next(m)).collect();
            values.sort_unstable();
            let (shift, turn) = (next(m), next(n));
            let mapping: Vec<usize> = (0..n).map(|i| (values[(i + turn) % n] + shift) % m).collect();
            let expected: Vec<usize> = (0..n)
                .map(|i| {
                    let v = mapping[i];
                    if mapping.iter().all(|&w| w == v) {
                        return v;
                    }
                    let back = (1..n).take_while(|&d| mapping[(i + n - d) % n] == v).count();
                    let fwd = (1..n).take_while(|&d| mapping[(i + d) % n] == v).count();
                    let len = back + fwd + 1;
                    if len < RESPREAD_RUN {
                        return v;
                    }
                    let before = mapping[(i + n - back - 1) % n];
                    let after = mapping[(i + fwd + 1) % n];
                    let span = match (after + m - before) % m {
                        0 => m,
                        d => d,
                    };
                    let k = back as f64;
                    (before + ((k + 0.5) * span as f64 / len as f64).round() as usize) % m
                })
                .collect();
            let got = respread(&mapping, m);
            assert_eq!(got.clone().unwrap_or_else(|| mapping.clone()), expected, "{mapping:?}");
            assert_eq!(got.is_some(), expected != mapping, "{mapping:?}");
            spread += usize::from(got.is_some());
            // The same mapping with the target numbered from elsewhere, and the source.
            let c = next(m);
            let shifted: Vec<usize> = mapping.iter().map(|&j| (j + c) % m).collect();
            let want: Vec<usize> = expected.iter().map(|&j| (j + c) % m).collect();
            assert_eq!(
                respread(&shifted, m).unwrap_or(shifted.clone()),
                want,
                "{mapping:?} + {c}"
            );
            let r = next(n);
            let turned: Vec<usize> = (0..n).map(|i| mapping[(i + r) % n]).collect();
            let want: Vec<usize> = (0..n).map(|i| expected[(i + r) % n]).collect();
            assert_eq!(
                respread(&turned, m).unwrap_or(turned.clone()),
                want,
                "{mapping:?} turned {r}"
            );
        }
        assert!(spread > 300, "only {spread} of 3000 mappings had a run to spread");
    }

    #[test]
    fn respreading_never_raises_a_frame_cost_and_frees_a_piled_fit() {
        let (t, fit, plan, samples) = fitted_tiles();
        let mut freed = 0;
        for f in 1..t.len() {
            let grid = TargetGrid::new(&t[f]);
            // A seed piled into runs longer than RESPREAD_RUN, and a local search too narrow to
            // leave it (three candidates per vertex, no re-centring, no sweeps): only the
            // respread seed can.
            let m = fit.targets[f].len();
            let n = fit.key_polygon.len();
            let run = RESPREAD_RUN + 1;
            let piled: Vec<usize> = (0..n).map(|i| (i / run * run) * m / n).collect();
            let seed = [Seed {
                positions: piled.iter().map(|&j| fit.targets[f][j]).collect(),
                indices: Some(piled.clone()),
                cost: None,
                stuck: false,
            }];
            let solve = |respread: bool, narrow: bool| {
                let mut o = PartFitOptions {
                    respread,
                    restart_threshold: f64::INFINITY,
                    ..Default::default()
                };
                if narrow {
                    (o.window, o.hint_radius, o.refine_passes, o.sweeps) = (3, 0, 0, 0);
                }
                fit_frame(&plan, &samples, &grid, &fit.targets[f], &seed, &o, &[]).unwrap()
            };
            for narrow in [false, true] {
                let (plain, spread) = (solve(false, narrow), solve(true, narrow));
                assert!(
                    spread.cost <= plain.cost + 1e-9,
                    "frame {f}: {} > {}",
                    spread.cost,
                    plain.cost
                );
                if narrow && spread.cost < plain.cost - 1e-9 {
                    freed += 1;
                }
            }
        }
        assert!(freed > 0, "the respread seed never beat a piled fit");
    }

    #[test]
    fn stuck_neighbours_spare_a_restart_only_while_the_cost_does_not_rise() {
        let (t, fit, plan, samples) = fitted_tiles();
        let mut trusted_some = false;
        for f in 1..t.len() {
            let grid = TargetGrid::new(&t[f]);
            let solve = |restart_threshold: f64, restart_trust: f64, stuck: bool, cost: Option<f64>| {
                let o = PartFitOptions {
                    restart_threshold,
                    restart_trust,
                    ..Default::default()
                };
                // A poor seed (every vertex expected half-way round the outline), so that
                // restarting helps.
                let n = fit.key_polygon.len();
                let seed = [Seed {
                    positions: (0..n).map(|i| fit.key_polygon[(i + n / 2) % n]).collect(),
                    indices: None,
                    cost,
                    stuck,
                }];
                fit_frame_stuck(&plan, &samples, &grid, &fit.targets[f], &seed, &o, &[]).unwrap()
            };
            // Every frame is over a zero threshold.
            let (local, _) = solve(f64::INFINITY, 0.0, false, None);
            let (restarted, _) = solve(0.0, 0.0, false, None);
            // Stuck neighbours that cost more: no restart, and this frame is stuck in turn.
            let (spared, stuck) = solve(0.0, 1.0, true, Some(local.cost * 2.0 + 1.0));
            assert_eq!(spared, local, "frame {f}: a trusted frame is the local search's");
            assert!(stuck, "frame {f}: a trusted frame passes its state on");
            // Stuck neighbours that cost less (the cost rose), or neighbours not stuck: the
            // restart runs as without the rule.
            let (rose, _) = solve(0.0, 1.0, true, Some(local.cost * 0.5));
            assert_eq!(rose, restarted, "frame {f}");
            let (fresh, _) = solve(0.0, 1.0, false, Some(local.cost * 2.0 + 1.0));
            assert_eq!(fresh, restarted, "frame {f}");
            trusted_some |= restarted.cost < local.cost;
        }
        // The fixture has frames a restart improves, so the rule had something to skip.
        assert!(trusted_some, "no frame improved by restarting: the test shows nothing");
    }

    #[test]
    fn a_part_holding_still_reuses_its_neighbours_fit() {
        let mut t = tiles(6);
        t[3] = t[2].clone();
        let fit = fit_part(&t, 0, &PartFitOptions::default(), &[]).unwrap();
        assert_eq!(fit.mappings[3], fit.mappings[2]);
        assert_eq!(fit.costs[3], fit.costs[2]);
        // The reused answer is a real fit of that frame: its cost is what it costs there.
        let samples = SourceSamples::new(&t[0], &fit.key_polygon, &fit.key_triangles, true);
        let grid = TargetGrid::with_outline(&t[3], &fit.targets[3]);
        let again = crate::bake::fit::mapping_cost(&fit.key_triangles, &fit.mappings[3], |k, p| {
            samples.cost_indexed(k, &grid, &fit.targets[3], p, f64::INFINITY)
        });
        assert!(
            (again - fit.costs[3]).abs() <= 1e-9 * again.max(1.0),
            "{again} vs {}",
            fit.costs[3]
        );
    }

    #[test]
    fn the_walk_visits_every_frame_once_from_fitted_neighbours() {
        for frames in 1..12 {
            for key in 0..frames {
                let order = walk_order(frames, key);
                let mut seen = vec![false; frames];
                for (s, (f, neighbours)) in order.iter().enumerate() {
                    assert!(!seen[*f], "{frames} frames, key {key}: {f} twice");
                    // Every frame but the key starts from a fitted neighbour...
                    assert_eq!(neighbours.is_empty(), s == 0);
                    for &g in neighbours {
                        assert!(seen[g] && ((g + 1) % frames == *f || (f + 1) % frames == g));
                    }
                    // ... at most half the loop away from the key.
                    let d = (f + frames - key) % frames;
                    assert!(d.min(frames - d) <= frames / 2);
                    seen[*f] = true;
                }
                assert!(seen.iter().all(|&x| x));
                assert_eq!(order[0].0, key);
                // The last frame, opposite the key, starts from both sides.
                if frames >= 3 {
                    assert_eq!(order[frames - 1].1.len(), 2, "{frames} frames, key {key}");
                }
            }
        }
    }

    #[test]
    fn the_cost_cache_gives_every_triple_its_own_cell_dense_or_sparse() {
        // A fan of 4 triangles over 6 vertices, 5 target vertices: every (triangle, triple)
        // written with its own value, in a scrambled order, then read back.
        let tris = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]];
        let plan = Plan::new(6, &tris).unwrap();
        let m = 5;
        let mut all = Vec::new();
        for t in 0..tris.len() {
            for a in 0..m {
                for b in 0..m {
                    for c in 0..m {
                        all.push((t, [a, b, c]));
                    }
                }
            }
        }
        let value = |t: usize, p: [usize; 3]| (t * 1000 + p[0] * 100 + p[1] * 10 + p[2]) as f64;
        let mut dense = CostCache::new(&plan, m);
        assert!(matches!(dense.rows, RowIndex::Dense(_)));
        let mut sparse = CostCache::new(&plan, m);
        sparse.rows = RowIndex::Sparse(Default::default());
        for cache in [&mut dense, &mut sparse] {
            for k in 0..all.len() {
                let (t, p) = all[(k * 37) % all.len()];
                assert!(cache.cell(t, p).is_nan(), "fresh cells are empty");
                *cache.cell(t, p) = value(t, p);
            }
            for &(t, p) in &all {
                assert_eq!(*cache.cell(t, p), value(t, p));
            }
        }
    }

    #[test]
    fn a_pin_is_respected() {
        let t = tiles(3);
        let free = fit_part(&t, 0, &PartFitOptions::default(), &[]).unwrap();
        let j = (free.mappings[1][0] + 5) % free.targets[1].len();
        let pinned = fit_part(&t, 0, &PartFitOptions::default(), &[vec![], vec![(0, j)], vec![]]).unwrap();
        assert_eq!(pinned.mappings[1][0], j);
        assert!(pinned.costs[1] >= free.costs[1] - 1e-9);
    }

    #[test]
    fn span_membership_and_nearest_frame_match_brute_force() {
        for frames in 1..9usize {
            for start in 0..frames {
                for count in 0..=frames {
                    let span = Span { start, count };
                    let members: Vec<usize> = (0..count).map(|d| (start + d) % frames).collect();
                    for f in 0..frames {
                        assert_eq!(
                            span.contains(f, frames),
                            members.contains(&f),
                            "{span:?} of {frames}: {f}"
                        );
                        if count == 0 {
                            continue;
                        }
                        // Nearest member round the loop (ties either way are fine).
                        let dist = |a: usize, b: usize| ((a + frames - b) % frames).min((b + frames - a) % frames);
                        let best = members.iter().map(|&m| dist(m, f)).min().unwrap();
                        let got = span.nearest(f, frames);
                        assert!(members.contains(&got), "{span:?}: nearest of {f} is {got}, outside");
                        assert_eq!(dist(got, f), best, "{span:?} of {frames}: nearest of {f} is {got}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_span_fit_stops_each_way_after_its_first_loss() {
        let t = tiles(8);
        let options = PartFitOptions::default();
        let targets = frame_targets(&t, &options).unwrap();
        let key = 5;
        // Never losing: every frame, exactly as the whole fit.
        let whole = fit_part(&t, key, &options, &[]).unwrap();
        let (all, span) = fit_part_span(&t, &targets, key, &options, &[], Some(&|_, _| false)).unwrap();
        assert_eq!(span.count, 8);
        assert_eq!(all.mappings, whole.mappings);
        assert_eq!(all.costs, whole.costs);
        // Always losing: the key and one frame each way, the rest borrowed and infinite.
        let (few, span) = fit_part_span(&t, &targets, key, &options, &[], Some(&|_, _| true)).unwrap();
        assert_eq!(span, Span { start: 4, count: 3 });
        for f in 0..8 {
            assert_eq!(few.costs[f].is_finite(), span.contains(f, 8), "frame {f}");
            if !span.contains(f, 8) {
                let g = span.nearest(f, 8);
                assert_eq!(few.positions(f), few.positions(g), "frame {f} borrows frame {g}");
            }
        }
        // Losing from frame 7 on: forward stops at 7 (kept), backward runs until it meets it.
        let (_, span) = fit_part_span(&t, &targets, key, &options, &[], Some(&|f, _| f == 7 || f == 1)).unwrap();
        assert_eq!(span, Span { start: 1, count: 7 }, "frames 1..=7");
    }
}
