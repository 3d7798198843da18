//! Body-part segmentation: per-triangle part labels, computed automatically from the skin
//! weights and the joint hierarchy (the trunk chain plus one part per limb chain), then
//! painted by the artist.
//!
//! Limbs are found as mirror pairs of child chains hanging off the trunk (by name —
//! Left/Right, L/R tokens — or, failing that, by shape: same chain length, mirrored offsets).
//! The trunk continues through the remaining child with the largest subtree. A humanoid
//! gives the paper's five parts (torso with head, two arms, two legs); a quadruped gives
//! four legs plus body (plus a tail if long enough); a 2-joint rig gives one part.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::character::Character;

/// A body part.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// Display name, unique within an automatic segmentation (`Torso`, `Left Arm`,
    /// `Front Right Leg`, `Tail`, ...).
    pub name: String,
    /// Display colour (sRGB bytes).
    pub color: [u8; 3],
}

/// Per-triangle part labels and the parts they refer to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Segmentation {
    /// The parts, which `labels` index. In an automatic segmentation part 0 is the trunk
    /// (`Torso`).
    pub parts: Vec<Part>,
    /// `labels[t]` is the part of triangle `t` of the character.
    pub labels: Vec<u16>,
}

/// Part display colours, in the order parts get them.
pub const PALETTE: [[u8; 3]; 10] = [
    [230, 160, 60],
    [70, 150, 230],
    [90, 200, 110],
    [220, 80, 90],
    [170, 110, 220],
    [60, 200, 200],
    [220, 210, 70],
    [200, 120, 160],
    [140, 180, 60],
    [120, 130, 240],
];

/// Colours of the parts after the first ten: darker and lighter ones, each clearly apart
/// from the [`PALETTE`] and from each other.
const MORE_COLORS: [[u8; 3]; 10] = [
    [120, 70, 30],
    [30, 90, 160],
    [30, 120, 60],
    [140, 30, 50],
    [100, 50, 140],
    [20, 130, 130],
    [170, 130, 0],
    [250, 200, 220],
    [200, 240, 150],
    [180, 200, 250],
];

/// Display colour of the `i`-th part: [`PALETTE`] for the first ten, [`MORE_COLORS`] for the
/// next ten (up to the part limit), then round again (the palette alone repeated itself from
/// the eleventh part on).
pub fn part_color(i: usize) -> [u8; 3] {
    let k = i % (PALETTE.len() + MORE_COLORS.len());
    PALETTE
        .get(k)
        .copied()
        .unwrap_or_else(|| MORE_COLORS[k - PALETTE.len()])
}

impl Segmentation {
    /// Triangles of one part.
    pub fn triangles_of(&self, part: usize) -> Vec<usize> {
        self.labels
            .iter()
            .enumerate()
            .filter(|(_, l)| **l as usize == part)
            .map(|(t, _)| t)
            .collect()
    }

    /// Triangle count per part.
    pub fn part_sizes(&self) -> Vec<usize> {
        let mut n = vec![0; self.parts.len()];
        for &l in &self.labels {
            if let Some(c) = n.get_mut(l as usize) {
                *c += 1;
            }
        }
        n
    }
}

/// Name tokens without side markers, lower case, for matching mirror pairs.
fn side_free_name(name: &str) -> (String, Option<char>) {
    let mut tokens: Vec<String> = Vec::new();
    let mut cur = String::new();
    let chars: Vec<char> = name.chars().collect();
    for (i, &c) in chars.iter().enumerate() {
        let boundary = !c.is_alphanumeric()
            || (c.is_uppercase() && i > 0 && chars[i - 1].is_lowercase())
            || (c.is_ascii_digit() != chars.get(i.wrapping_sub(1)).is_some_and(|p| p.is_ascii_digit()) && i > 0);
        if boundary && !cur.is_empty() {
            tokens.push(std::mem::take(&mut cur).to_lowercase());
        }
        if c.is_alphanumeric() {
            cur.push(c);
        }
    }
    if !cur.is_empty() {
        tokens.push(cur.to_lowercase());
    }
    let mut side = None;
    let kept: Vec<String> = tokens
        .into_iter()
        .filter(|t| match t.as_str() {
            "left" | "l" => {
                side = Some('l');
                false
            }
            "right" | "r" => {
                side = Some('r');
                false
            }
            _ => true,
        })
        .collect();
    (kept.join("_"), side)
}

struct JointTree {
    /// Skeleton node index of each joint.
    node: Vec<usize>,
    parent: Vec<Option<usize>>,
    children: Vec<Vec<usize>>,
    /// Rest-pose world position.
    pos: Vec<Vec3>,
    name: Vec<String>,
    /// Skin weight carried by the joint's subtree.
    mass: Vec<f64>,
    /// Joints in the subtree (itself included).
    size: Vec<usize>,
}

/// Share of all skin weight at or under which a joint's subtree counts as carrying nothing
/// ([`JointTree::new`]; at least 0.02 of one vertex's weight): a hundred-thousandth (a vertex
/// at weight 0.05 in a mesh of 5,000).
const EMPTY_SUBTREE_WEIGHT: f64 = 1e-5;

/// The weight of the whole mesh: the sum over the roots of the subtree sums.
fn own_weight_total(subtree_weight: &[f64], nodes: &[crate::character::Node]) -> f64 {
    nodes
        .iter()
        .zip(subtree_weight)
        .filter(|(n, _)| n.parent.is_none())
        .map(|(_, w)| *w)
        .sum()
}

impl JointTree {
    fn new(c: &Character) -> Self {
        let nodes = &c.skeleton.nodes;
        let world = c.skeleton.rest_world();
        // Joints: skin joints, or every node when the file had none marked.
        let mut is_joint: Vec<bool> = nodes.iter().map(|n| n.is_joint).collect();
        if !is_joint.iter().any(|&j| j) {
            is_joint = vec![true; nodes.len()];
        }
        // Chains of joints whose whole subtree carries no skin weight (an IK target or pole
        // chain, a tail or cape chain with nothing on it yet) take no part in the structure,
        // when any joint carries weight: counted, a 10-joint empty chain under the hips became
        // the trunk and took the arms with the spine into one part, and three empty joints
        // named "Tail…" turned a box rig's legs into "Tail Prop"s. A single empty joint (an
        // end marker such as `HeadTop_End`, a lone IK target) stays: the rules below were
        // made with those counted, and deal with single joints themselves.
        let mut own_weight = vec![0.0f64; nodes.len()];
        for v in &c.vertices {
            for k in 0..4 {
                if let Some(b) = c.bones.get(v.bones[k] as usize)
                    && let Some(w) = own_weight.get_mut(b.node)
                {
                    *w += v.weights[k].max(0.0) as f64;
                }
            }
        }
        let mut subtree_weight = own_weight;
        for n in (0..nodes.len()).rev() {
            if let Some(p) = nodes[n].parent
                && p < n
            {
                subtree_weight[p] += subtree_weight[n];
            }
        }
        // (Weights of a few thousandths on one vertex, as exporters leave on control bones,
        // count as none: at most EMPTY_SUBTREE_WEIGHT of all the weight, or a fiftieth of one
        // vertex's.)
        let total: f64 = own_weight_total(&subtree_weight, nodes);
        if total > 0.0 {
            let limit = (EMPTY_SUBTREE_WEIGHT * total).max(0.02);
            let empty: Vec<bool> = subtree_weight.iter().map(|&w| w <= limit).collect();
            // Joints in each node's subtree (parents first, so children come later).
            let mut joints_under: Vec<usize> = is_joint.iter().map(|&j| usize::from(j)).collect();
            for n in (0..nodes.len()).rev() {
                if let Some(p) = nodes[n].parent
                    && p < n
                {
                    joints_under[p] += joints_under[n];
                }
            }
            // An empty subtree's root: empty, under a node that is not (or a root).
            let mut drop = vec![false; nodes.len()];
            for n in 0..nodes.len() {
                let parent_drops = nodes[n].parent.is_some_and(|p| p < n && drop[p]);
                let root_of_empty = empty[n] && nodes[n].parent.is_none_or(|p| !empty[p]);
                drop[n] = parent_drops || (root_of_empty && joints_under[n] >= 2);
            }
            for n in 0..nodes.len() {
                if drop[n] {
                    is_joint[n] = false;
                }
            }
        }
        let node: Vec<usize> = (0..nodes.len()).filter(|&i| is_joint[i]).collect();
        let index_of = |n: usize| node.iter().position(|&x| x == n);
        let parent: Vec<Option<usize>> = node
            .iter()
            .map(|&n| {
                let mut at = nodes[n].parent;
                while let Some(p) = at {
                    if let Some(j) = index_of(p) {
                        return Some(j);
                    }
                    at = nodes[p].parent;
                }
                None
            })
            .collect();
        let mut children = vec![Vec::new(); node.len()];
        for (j, p) in parent.iter().enumerate() {
            if let Some(p) = p {
                children[*p].push(j);
            }
        }
        let mut own = vec![0.0f64; node.len()];
        for v in &c.vertices {
            for k in 0..4 {
                if let Some(b) = c.bones.get(v.bones[k] as usize) {
                    if let Some(j) = joint_of_node(c, &node, b.node) {
                        own[j] += v.weights[k] as f64;
                    }
                }
            }
        }
        // Subtree sums: nodes are stored parents first, so children have larger indices.
        let mut mass = own.clone();
        let mut size = vec![1usize; node.len()];
        for j in (0..node.len()).rev() {
            if let Some(p) = parent[j] {
                mass[p] += mass[j];
                size[p] += size[j];
            }
        }
        Self {
            pos: node.iter().map(|&n| world[n].w_axis.truncate()).collect(),
            name: node.iter().map(|&n| nodes[n].name.clone()).collect(),
            node,
            parent,
            children,
            mass,
            size,
        }
    }

    fn is_mirror_pair(&self, a: usize, b: usize) -> bool {
        let (na, sa) = side_free_name(&self.name[a]);
        let (nb, sb) = side_free_name(&self.name[b]);
        if let (Some(sa), Some(sb)) = (sa, sb) {
            if sa == sb {
                return false;
            }
            let strip = |n: &str| {
                n.chars()
                    .filter(|c| !c.is_ascii_digit() && *c != '_')
                    .collect::<String>()
            };
            if strip(&na) == strip(&nb) {
                return true;
            }
        }
        // Shape: same subtree size, offsets of similar length pointing apart, or mirror
        // images of each other across the character's middle plane (x = 0: glTF's front is
        // +z; shoulders set high above the chest point apart by less than 50°).
        let p = self.parent[a].map_or(Vec3::ZERO, |p| self.pos[p]);
        let (da, db) = (self.pos[a] - p, self.pos[b] - p);
        let (la, lb) = (da.length(), db.length());
        let mirrored = (da - Vec3::new(-db.x, db.y, db.z)).length() <= 0.2 * la.max(lb)
            && da.x.abs() >= 0.15 * la
            && da.x * db.x < 0.0;
        // (Single joints pair only as mirror images: a foot's IK joint beside each leg.)
        self.size[a] == self.size[b]
            && la > 0.0
            && lb > 0.0
            && (la - lb).abs() <= 0.3 * la.max(lb)
            && ((self.size[a] >= 2 && da.angle_between(db) > 50f32.to_radians()) || mirrored)
    }
}

/// Joint index (in `nodes`) of a skeleton node: itself if a joint, else its nearest joint
/// ancestor.
fn joint_of_node(c: &Character, joints: &[usize], mut n: usize) -> Option<usize> {
    loop {
        if let Some(j) = joints.iter().position(|&x| x == n) {
            return Some(j);
        }
        n = c.skeleton.nodes.get(n)?.parent?;
    }
}

/// The automatic segmentation.
pub fn auto_segment(c: &Character) -> Segmentation {
    if let Some(seg) = moving_pieces(c)
        .or_else(|| morphing_pieces(c))
        .or_else(|| morphing_motion_parts(c))
    {
        return seg;
    }
    let mut seg = skeleton_parts(c).0;
    let rest = crate::animation::skin_vertices(c, &crate::animation::Pose::rest(c)).0;
    tidy_islands_with(
        &neighbours_at(c, &rest),
        &mut seg.labels,
        Some(&triangle_centroids(c, &rest)),
    );
    // Drop parts that received no triangle (keeps labels dense).
    compact(&mut seg);
    seg
}

/// Which leg each vertex of `c` belongs to, by its largest share of skin weight: `Some(k)`
/// for the `k`-th leg [`auto_segment`] finds (limbs in mirror pairs that reach the ground from
/// the lowest-hung pairs: a humanoid's two, a quadruped's four; not a robot's long arms that
/// reach down), `None` for the rest. Empty when the character has fewer than two legs or is a
/// prop of moving pieces. What touches the ground when it walks: [`crate::timeline`] measures
/// stride speed on these.
pub fn leg_vertices(c: &Character) -> Vec<Option<usize>> {
    if moving_pieces(c).is_some() {
        return Vec::new();
    }
    let (_, legs, vertex_weights) = skeleton_parts(c);
    let leg_index: Vec<Option<usize>> = legs
        .iter()
        .scan(0usize, |n, &is| {
            Some(is.then(|| {
                *n += 1;
                *n - 1
            }))
        })
        .collect();
    if leg_index.iter().flatten().count() < 2 {
        return Vec::new();
    }
    vertex_weights
        .iter()
        .map(|w| {
            (0..w.len())
                .max_by(|&a, &b| w[a].total_cmp(&w[b]).then(b.cmp(&a)))
                .and_then(|p| leg_index.get(p).copied().flatten())
        })
        .collect()
}

/// The skeleton's parts before empty ones are dropped, whether each is a leg, and each
/// vertex's skin weight per part.
#[allow(clippy::type_complexity)]
fn skeleton_parts(c: &Character) -> (Segmentation, Vec<bool>, Vec<Vec<f32>>) {
    let tree = JointTree::new(c);
    let count = tree.node.len();
    // part_of_joint[j]: the part each joint's influence goes to (0 = trunk).
    let mut part_of_joint = vec![0usize; count];
    let mut parts = vec![Part {
        name: "Torso".into(),
        color: PALETTE[0],
    }];
    let mut leg_parts: Vec<usize> = Vec::new();
    let mut rigid_props: Vec<(usize, usize)> = Vec::new();
    let mut prop_triangles: Vec<Option<usize>> = Vec::new();
    if count > 0 {
        let root = (0..count)
            .filter(|&j| tree.parent[j].is_none())
            .max_by(|&a, &b| tree.mass[a].total_cmp(&tree.mass[b]).then(b.cmp(&a)));
        let mut at = root;
        let mut limb_roots: Vec<usize> = Vec::new();
        // partner[j]: the other limb of the mirror pair joint `j` roots.
        let mut partner: Vec<Option<usize>> = vec![None; count];
        // The trunk's joints, root first (the head end last).
        let mut trunk: Vec<usize> = Vec::new();
        while let Some(j) = at {
            trunk.push(j);
            let kids = &tree.children[j];
            let mut paired = vec![false; kids.len()];
            for x in 0..kids.len() {
                for y in x + 1..kids.len() {
                    if !paired[x] && !paired[y] && tree.is_mirror_pair(kids[x], kids[y]) {
                        paired[x] = true;
                        paired[y] = true;
                        partner[kids[x]] = Some(kids[y]);
                        partner[kids[y]] = Some(kids[x]);
                    }
                }
            }
            for (k, &child) in kids.iter().enumerate() {
                if paired[k] {
                    limb_roots.push(child);
                }
            }
            // The trunk goes on through the biggest unpaired child.
            let next = kids
                .iter()
                .enumerate()
                .filter(|(k, _)| !paired[*k])
                .max_by(|a, b| {
                    tree.size[*a.1]
                        .cmp(&tree.size[*b.1])
                        .then(tree.mass[*a.1].total_cmp(&tree.mass[*b.1]))
                })
                .map(|(_, &c)| c);
            // Other long unpaired branches (a tail) become parts of their own.
            for (k, &child) in kids.iter().enumerate() {
                if !paired[k] && Some(child) != next && tree.size[child] >= 3 {
                    limb_roots.push(child);
                }
            }
            at = next;
        }
        let subtree = |r: usize| {
            let mut out = Vec::new();
            let mut stack = vec![r];
            while let Some(j) = stack.pop() {
                out.push(j);
                stack.extend(tree.children[j].iter().copied());
            }
            out
        };
        let limbs: Vec<(usize, Vec<usize>)> = limb_roots.iter().map(|&r| (r, subtree(r))).collect();
        // Each limb's side: from its name (Left/Right, L/R tokens), else, for a mirror pair
        // found by shape (a rig whose names say nothing), from where it hangs: glTF's front
        // is +z and its up +y, so a character's left is +x (import turns walkers to face +z).
        let side: Vec<Option<char>> = limbs
            .iter()
            .map(|&(r, _)| {
                side_free_name(&tree.name[r]).1.or_else(|| {
                    let d = tree.pos[r] - tree.pos[partner[r]?];
                    (d.x.abs() > d.z.abs()).then_some(if d.x > 0.0 { 'l' } else { 'r' })
                })
            })
            .collect();
        let paired = |i: usize| side[i].is_some() || partner[limbs[i].0].is_some();
        // Rest-pose mesh: which vertices each joint carries (by its largest weight).
        let rest = crate::animation::skin_vertices(c, &crate::animation::Pose::rest(c)).0;
        let bone_joint: Vec<Option<usize>> = c.bones.iter().map(|b| joint_of_node(c, &tree.node, b.node)).collect();
        let mut carried: Vec<Vec<Vec3>> = vec![Vec::new(); count];
        for (v, p) in c.vertices.iter().zip(&rest) {
            if let Some(Some(j)) = bone_joint.get(main_bone(v)) {
                carried[*j].push(*p);
            }
        }
        // Rest-pose surface area each joint carries (a triangle's third per corner, to the
        // corner's joint): a share of the mesh that does not grow with how finely a piece is
        // subdivided.
        let mut carried_area = vec![0.0f64; count];
        for t in c.indices.chunks_exact(3) {
            let [a, b, d] = [t[0], t[1], t[2]].map(|i| rest.get(i as usize).copied().unwrap_or(Vec3::ZERO));
            let third = 0.5 * (b - a).cross(d - a).length() as f64 / 3.0;
            if !third.is_finite() {
                continue;
            }
            for &i in t {
                if let Some(v) = c.vertices.get(i as usize)
                    && let Some(Some(j)) = bone_joint.get(main_bone(v))
                {
                    carried_area[*j] += third;
                }
            }
        }
        let area_all: f64 = carried_area.iter().sum();
        let (ground, top) = rest.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
        let (ground, top) = if ground <= top {
            (ground, top)
        } else {
            let ys = tree.pos.iter().map(|p| p.y);
            (
                ys.clone().fold(f32::INFINITY, f32::min),
                ys.fold(f32::NEG_INFINITY, f32::max),
            )
        };
        // A floor relative to the rig's own size (an absolute one took a character a tenth of a
        // millimetre tall for one lying flat, and named its arms as legs).
        let (lo, hi) = crate::character::bounds(tree.pos.iter().chain(&rest).copied());
        let extent = (hi - lo).max_element();
        let span = (top - ground).max(1e-3 * extent).max(f32::MIN_POSITIVE);
        // Points of a set of joints: their mesh where they carry any, else the joints.
        let points = |joints: &[usize]| -> Vec<Vec3> {
            let mesh: Vec<Vec3> = joints.iter().flat_map(|&j| carried[j].iter().copied()).collect();
            if mesh.is_empty() {
                joints.iter().map(|&j| tree.pos[j]).collect()
            } else {
                mesh
            }
        };
        // Closest distance between two point sets (subsampled to keep it cheap).
        let gap = |a: &[Vec3], b: &[Vec3]| {
            let (sa, sb) = ((a.len() / 300).max(1), (b.len() / 300).max(1));
            a.iter()
                .step_by(sa)
                .flat_map(|p| b.iter().step_by(sb).map(move |q| p.distance(*q)))
                .fold(f32::INFINITY, f32::min)
        };
        // A single-joint "limb" (an IK foot, a prop) joins the real limb its mesh touches
        // (an IK foot sits under its leg), else the trunk — unless it carries a share of the
        // mesh of its own (at least SINGLE_JOINT_LIMB_SHARE of the vertices or of the surface): a rig with one
        // joint per limb (a box or voxel character) has limbs all the same, and put in the
        // trunk they made one part that no warped image could follow.
        let carried_all: usize = carried.iter().map(Vec::len).sum();
        let mut target: Vec<Option<usize>> = vec![None; limbs.len()];
        for (i, (_, joints)) in limbs.iter().enumerate() {
            if joints.len() > 1 {
                target[i] = Some(i);
                continue;
            }
            let own = points(joints);
            target[i] = limbs
                .iter()
                .enumerate()
                .filter(|(k, l)| *k != i && l.1.len() > 1)
                .map(|(k, l)| (k, gap(&own, &points(&l.1))))
                .filter(|(_, d)| *d < 0.1 * span)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| k);
            // The share of the vertices or of the surface, whichever is larger: a limb of a
            // few big boxes beside one finely subdivided piece (a chest plate of 5,000
            // triangles) holds few vertices but much of the surface.
            let vertex_share =
                joints.iter().map(|&j| carried[j].len()).sum::<usize>() as f64 / carried_all.max(1) as f64;
            let area_share = if area_all > 0.0 {
                joints.iter().map(|&j| carried_area[j]).sum::<f64>() / area_all
            } else {
                0.0
            };
            let share = vertex_share.max(area_share);
            // A limb is long too: eyes (a mirrored pair of one joint each, with a mesh of
            // their own) are no limbs, however many vertices they hold.
            let (lo, hi) = crate::character::bounds(joints.iter().flat_map(|&j| carried[j].iter().copied()));
            let long = (hi - lo).max_element() >= SINGLE_JOINT_LIMB_LENGTH * span;
            if target[i].is_none() && share >= SINGLE_JOINT_LIMB_SHARE && long {
                target[i] = Some(i);
            }
        }
        // A limb that carries no mesh (an IK target chain, a pole, a control: rigs keep them
        // among the skin's joints) is no part: it names nothing and decides nothing — when
        // the character has a mesh at all.
        let any_mesh = carried.iter().any(|v| !v.is_empty());
        let meshless: Vec<bool> = (0..limbs.len())
            .map(|i| {
                any_mesh
                    && target[i] == Some(i)
                    && (0..limbs.len())
                        .filter(|&k| target[k] == Some(i))
                        .all(|k| limbs[k].1.iter().all(|&j| carried[j].is_empty()))
            })
            .collect();
        for k in 0..limbs.len() {
            if let Some(t) = target[k]
                && meshless[t]
            {
                target[k] = None;
            }
        }
        // What each real limb covers, its joined single joints included.
        let reach: Vec<(f32, bool)> = (0..limbs.len())
            .map(|i| {
                let joints: Vec<usize> = (0..limbs.len())
                    .filter(|&k| target[k] == Some(i))
                    .flat_map(|k| limbs[k].1.iter().copied())
                    .collect();
                let lowest = points(&joints).iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
                (tree.pos[limbs[i].0].y, paired(i) && lowest < ground + 0.25 * span)
            })
            .collect();
        // Paired limbs that reach the ground are legs, unless they hang from much higher up
        // than the lowest-hung pair that does (long arms that reach down, as on a robot or
        // an ape); the others are arms. Four legs on a quadruped hang from similar heights.
        let lowest_hip = reach
            .iter()
            .enumerate()
            .filter(|(i, r)| target[*i] == Some(*i) && r.1)
            .map(|(_, r)| r.0)
            .fold(f32::INFINITY, f32::min);
        let is_leg = |i: usize| {
            let (hip, grounded) = reach[i];
            target[i] == Some(i) && paired(i) && grounded && hip <= lowest_hip + 0.15 * span
        };
        // Several pairs of legs (a quadruped, an insect): front and hind by where they hang
        // along the trunk, the head's end being the front.
        let legs: Vec<usize> = (0..limbs.len()).filter(|&i| is_leg(i)).collect();
        let along = |j: usize| -> f32 {
            match (trunk.first(), trunk.last()) {
                (Some(&a), Some(&b)) if a != b => {
                    let axis = (tree.pos[b] - tree.pos[a]).normalize_or_zero();
                    (tree.pos[j] - tree.pos[a]).dot(axis)
                }
                _ => 0.0,
            }
        };
        let leg_pairs = legs.len() / 2;
        let (front_cut, hind_cut) = if leg_pairs >= 2 {
            let mut at: Vec<f32> = legs.iter().map(|&i| along(limbs[i].0)).collect();
            at.sort_by(f32::total_cmp);
            // The foremost pair is the front, the hindmost the hind, any between the middle.
            let n = at.len();
            (at[n - 2], at[1])
        } else {
            (f32::INFINITY, f32::NEG_INFINITY)
        };
        let mut part_of_limb = vec![0usize; limbs.len()];
        for (i, (r, _)) in limbs.iter().enumerate() {
            if target[i] != Some(i) {
                continue;
            }
            let base = side_free_name(&tree.name[*r]).0;
            let side_word = match side[i] {
                Some('l') => "Left ",
                Some('r') => "Right ",
                _ => "",
            };
            let kind = if !paired(i) {
                if base.to_ascii_lowercase().contains("tail") {
                    "Tail".to_string()
                } else {
                    pretty(&base)
                }
            } else if is_leg(i) {
                "Leg".to_string()
            } else {
                "Arm".to_string()
            };
            let kind = if kind.is_empty() { "Part".to_string() } else { kind };
            let end_word = if kind == "Leg" && leg_pairs >= 2 {
                let a = along(*r);
                if a > front_cut - 1e-6 * span && a >= hind_cut + 0.05 * span {
                    "Front "
                } else if a <= hind_cut + 1e-6 * span {
                    "Hind "
                } else {
                    "Middle "
                }
            } else {
                ""
            };
            let label = unique_name(&parts, &format!("{end_word}{side_word}{kind}"));
            part_of_limb[i] = parts.len();
            if is_leg(i) {
                leg_parts.push(parts.len());
            }
            parts.push(Part {
                name: label,
                color: part_color(parts.len()),
            });
        }
        for (i, (_, joints)) in limbs.iter().enumerate() {
            let part = target[i].map_or(0, |t| part_of_limb[t]);
            for &j in joints {
                part_of_joint[j] = part;
            }
        }
        // Props: inside a limb, a joint whose mesh is a piece of its own (no edge joins it
        // to the rest of the mesh in the rest pose) and reaches far from the limb's bones —
        // a spear in a hand, a shield on a forearm — is a part of its own. One warped image
        // of the arm cannot hold a spear turning about the hand: seen from above, the spear
        // vanished and the shield became a shard. Pieces that hug their bones (a robot's
        // hands and shins, a helmet) stay with their limb.
        let roots: Vec<usize> = (0..limbs.len())
            .filter(|&i| target[i] == Some(i))
            .map(|i| limbs[i].0)
            .collect();
        (rigid_props, prop_triangles) = split_props(
            c,
            &tree,
            &rest,
            &bone_joint,
            &subtree,
            span,
            &leg_parts,
            &roots,
            &mut part_of_joint,
            &mut parts,
        );
        // The head: the trunk beyond the last joint a limb hangs from (neck and head, on a
        // quadruped as on a humanoid), a part of its own where it turns on its own — one
        // warped image of the torso cannot show a head turning away (RobotExpressive's
        // Dance: the torso's key showed the face where the mesh showed the back of the head).
        let attach = limbs
            .iter()
            .enumerate()
            .filter(|(i, _)| target[*i] == Some(*i))
            .filter_map(|(_, (r, _))| tree.parent[*r])
            .filter_map(|j| trunk.iter().position(|&t| t == j))
            .max();
        if let Some(k) = attach
            && k + 1 < trunk.len()
        {
            let joints = subtree(trunk[k + 1]);
            let carried_here: usize = joints
                .iter()
                .filter(|&&j| part_of_joint[j] == 0)
                .map(|&j| carried[j].len())
                .sum();
            let carried_all: usize = carried.iter().map(Vec::len).sum();
            let top = *trunk.last().expect("the trunk holds the head's joints");
            let turn = head_turn(c, tree.node[trunk[k]], tree.node[top]);
            let share = carried_here as f64 / carried_all.max(1) as f64;
            if turn > HEAD_TURN_DEGREES && (HEAD_SHARE..=HEAD_SHARE_MAX).contains(&share) {
                let name = unique_name(&parts, "Head");
                let part = parts.len();
                parts.push(Part {
                    name,
                    color: part_color(part),
                });
                for j in joints {
                    if part_of_joint[j] == 0 {
                        part_of_joint[j] = part;
                    }
                }
            }
        }
    }
    // Vertex parts by summed weight, triangle parts by the majority of weight.
    let mut bone_part: Vec<usize> = c
        .bones
        .iter()
        .map(|b| joint_of_node(c, &tree.node, b.node).map_or(0, |j| part_of_joint[j]))
        .collect();
    for (b, part) in rigid_props {
        bone_part[b] = part;
    }
    let np = parts.len();
    let vertex_weights: Vec<Vec<f32>> = c
        .vertices
        .iter()
        .map(|v| {
            let mut w = vec![0.0f32; np];
            for k in 0..4 {
                if let Some(&p) = bone_part.get(v.bones[k] as usize) {
                    w[p] += v.weights[k];
                }
            }
            w
        })
        .collect();
    let labels: Vec<u16> = c
        .indices
        .chunks_exact(3)
        .enumerate()
        .map(|(k, t)| {
            if let Some(Some(p)) = prop_triangles.get(k) {
                return *p as u16;
            }
            let mut w = vec![0.0f32; np];
            for &v in t {
                for (p, x) in vertex_weights[v as usize].iter().enumerate() {
                    w[p] += x;
                }
            }
            (0..np)
                .max_by(|&a, &b| w[a].total_cmp(&w[b]).then(b.cmp(&a)))
                .unwrap_or(0) as u16
        })
        .collect();
    let legs = (0..np).map(|p| leg_parts.contains(&p)).collect();
    (Segmentation { parts, labels }, legs, vertex_weights)
}

/// Share of the mesh's vertices, or of its rest-pose surface area, a limb of one joint must
/// carry to be a part of its own rather than join the trunk ([`skeleton_parts`]): a box
/// character's arm carries 8–15 %, an IK or control joint none.
pub const SINGLE_JOINT_LIMB_SHARE: f64 = 0.02;

/// Least length (a share of the character's height) of the mesh a limb of one joint carries
/// for it to be a part of its own: a box character's arm 0.34, its leg 0.47; an eye 0.02.
pub const SINGLE_JOINT_LIMB_LENGTH: f32 = 0.15;

/// How far (a share of the character's height) a separate piece inside a limb must reach
/// from the limb's bones to be a part of its own ([`split_props`]). Measured: a soldier's
/// spear 0.67 and shield 0.165, the `knight` variants' swords 0.34–0.38 (CesiumMan's 0.117)
/// and shields 0.13–0.26; pieces that are body: RobotExpressive's forearms 0.104, the
/// default's hands 0.094, X Bot's 0.02–0.05 (and in legs, which keep their props,
/// RobotExpressive's shins 0.119 and feet 0.19).
pub const PROP_REACH: f32 = 0.14;

/// Most parts [`split_props`] cuts out of single pieces skinned to a limb's joints (the
/// farthest-reaching first).
pub const PROP_PIECES_MAX: usize = 4;

/// Gives each prop a limb carries its own part (see the call in [`skeleton_parts`]): the
/// highest joint of a limb other than a leg (a robot's feet, a shoe: the leg), below its
/// root, whose subtree's mesh is made only of whole pieces (triangles joined by edges in the
/// rest pose, UV seams welded) that each reach at least [`PROP_REACH`] × `span` from the
/// limb's bones; each mesh bound rigidly to a node inside such a limb (a sword parented to
/// a hand, no skin) that is such pieces; and each single such piece skinned to one joint of
/// the limb (a spear weighted to the hand bone itself; a piece that follows two joints or
/// more bends with the limb and is skin).
/// The part is named after the joint or node, less a socket word ("WeaponSlot" →
/// "Weapon"), or after the limb ("Right Arm Prop"). Returns the rigid bones given a part,
/// with the part, and each triangle's part where a piece was given one (empty if none).
fn split_props(
    c: &Character,
    tree: &JointTree,
    rest: &[Vec3],
    bone_joint: &[Option<usize>],
    subtree: &dyn Fn(usize) -> Vec<usize>,
    span: f32,
    legs: &[usize],
    roots: &[usize],
    part_of_joint: &mut [usize],
    parts: &mut Vec<Part>,
) -> (Vec<(usize, usize)>, Vec<Option<usize>>) {
    let count = tree.node.len();
    let vertex_bone: Vec<usize> = c.vertices.iter().map(main_bone).collect();
    let vertex_joint: Vec<Option<usize>> = vertex_bone
        .iter()
        .map(|&b| bone_joint.get(b).copied().flatten())
        .collect();
    let (piece, pieces) = pieces_at(c, rest);
    let mut piece_vertices: Vec<Vec<u32>> = vec![Vec::new(); pieces];
    for (t, tri) in c.indices.chunks_exact(3).enumerate() {
        piece_vertices[piece[t]].extend_from_slice(tri);
    }
    for v in &mut piece_vertices {
        v.sort_unstable();
        v.dedup();
    }
    let mut vertex_piece = vec![usize::MAX; c.vertices.len()];
    for (k, vs) in piece_vertices.iter().enumerate() {
        for &v in vs {
            vertex_piece[v as usize] = k;
        }
    }
    // The limbs' own parts (the parts made here come after them).
    let limb_parts = parts.len();
    // The limb's bones, as segments (a prop's own joints among them: a prop rigged with a
    // chain of its own, a flail, hugs those and stays in the limb). A joint ending the limb
    // (no child joint in it) carries a bone too, running on as far again as the one before
    // it: a forearm with no hand joint below it (a box rig) holds the forearm's mesh, which
    // is no prop; a hand's short bone leaves a sword held in it reaching far.
    let limb_bones = |part_of_joint: &[usize], limb: usize| -> Vec<(Vec3, Vec3)> {
        let mut bones = Vec::new();
        for k in (0..count).filter(|&k| part_of_joint[k] == limb) {
            let Some(parent) = tree.parent[k] else { continue };
            let (a, b) = (tree.pos[parent], tree.pos[k]);
            bones.push((a, b));
            if !tree.children[k].iter().any(|&ch| part_of_joint[ch] == limb) {
                bones.push((b, b + (b - a)));
            }
        }
        bones
    };
    // How far piece `k` reaches from `bones` (its farthest point).
    let piece_reach = |k: usize, bones: &[(Vec3, Vec3)]| -> f32 {
        let vs = &piece_vertices[k];
        vs.iter()
            .step_by((vs.len() / 500).max(1))
            .map(|&v| {
                let p = rest[v as usize];
                bones
                    .iter()
                    .map(|&(a, b)| segment_distance(p, a, b))
                    .fold(f32::INFINITY, f32::min)
            })
            .fold(0.0f32, f32::max)
    };
    // Each piece's reach from its limb's bones as they stand (cleared for a limb when a
    // split takes bones from it), so that a long chain of separate pieces (a segmented
    // tail) measures each piece once, not once per joint above it.
    let mut reach_cache: std::collections::HashMap<(usize, usize), f32> = Default::default();
    let mut bones_cache: std::collections::HashMap<usize, Vec<(Vec3, Vec3)>> = Default::default();
    // Whether pieces `own` of limb `limb` are whole (every vertex `held`) and each reaches
    // at least [`PROP_REACH`] × `span` from the limb's bones.
    let far = |own: &[usize],
               held: &dyn Fn(usize) -> bool,
               limb: usize,
               part_of_joint: &[usize],
               reach_cache: &mut std::collections::HashMap<(usize, usize), f32>,
               bones_cache: &mut std::collections::HashMap<usize, Vec<(Vec3, Vec3)>>|
     -> bool {
        if own.is_empty() || !own.iter().all(|&k| piece_vertices[k].iter().all(|&v| held(v as usize))) {
            return false;
        }
        let bones = bones_cache
            .entry(limb)
            .or_insert_with(|| limb_bones(part_of_joint, limb));
        own.iter()
            .all(|&k| *reach_cache.entry((limb, k)).or_insert_with(|| piece_reach(k, bones)) >= PROP_REACH * span)
    };
    // The pieces each joint's and each bone's vertices lie in.
    let mut joint_pieces: Vec<Vec<usize>> = vec![Vec::new(); count];
    let mut bone_pieces: Vec<Vec<usize>> = vec![Vec::new(); c.bones.len()];
    for v in 0..c.vertices.len() {
        let k = vertex_piece[v];
        if k == usize::MAX {
            continue;
        }
        if let Some(j) = vertex_joint[v] {
            joint_pieces[j].push(k);
        }
        if let Some(b) = bone_pieces.get_mut(vertex_bone[v]) {
            b.push(k);
        }
    }
    for l in joint_pieces.iter_mut().chain(bone_pieces.iter_mut()) {
        l.sort_unstable();
        l.dedup();
    }
    let add_part = |name: &str, parts: &mut Vec<Part>| {
        let base = pretty(&side_free_name(name).0);
        let base = ["Slot", "Socket", "Attach", "Mount", "Holder"]
            .iter()
            .find_map(|w| base.strip_suffix(w).filter(|b| !b.trim().is_empty()))
            .unwrap_or(&base)
            .trim()
            .to_string();
        let base = if base.is_empty() { "Prop".to_string() } else { base };
        let name = unique_name(parts, &base);
        parts.push(Part {
            name,
            color: part_color(parts.len()),
        });
        parts.len() - 1
    };
    let mut split = vec![false; count];
    for j in 0..count {
        let limb = part_of_joint[j];
        let Some(parent) = tree.parent[j] else { continue };
        if limb == 0 || legs.contains(&limb) || part_of_joint[parent] != limb {
            continue;
        }
        // Nothing below a joint already split (joints are not ordered parents first).
        let mut above = tree.parent[j];
        let mut inside_split = false;
        while let Some(a) = above {
            inside_split |= split[a];
            above = tree.parent[a];
        }
        if inside_split {
            continue;
        }
        let joints = subtree(j);
        let mut in_subtree = vec![false; count];
        for &k in &joints {
            in_subtree[k] = true;
        }
        let held = |v: usize| vertex_joint[v].is_some_and(|k| in_subtree[k]);
        let mut own: Vec<usize> = joints.iter().flat_map(|&k| joint_pieces[k].iter().copied()).collect();
        own.sort_unstable();
        own.dedup();
        if !far(&own, &held, limb, part_of_joint, &mut reach_cache, &mut bones_cache) {
            continue;
        }
        split[j] = true;
        let part = add_part(&tree.name[j], parts);
        for k in joints {
            part_of_joint[k] = part;
        }
        reach_cache.retain(|&(l, _), _| l != limb);
        bones_cache.remove(&limb);
    }
    // Meshes bound rigidly to a node that is no joint, inside a limb.
    let mut rigid = Vec::new();
    for (b, bone) in c.bones.iter().enumerate() {
        let Some(j) = bone_joint[b] else { continue };
        let limb = part_of_joint[j];
        if limb == 0 || limb >= limb_parts || legs.contains(&limb) || tree.node[j] == bone.node {
            continue;
        }
        let held = |v: usize| vertex_bone[v] == b;
        if !far(
            &bone_pieces[b],
            &held,
            limb,
            part_of_joint,
            &mut reach_cache,
            &mut bones_cache,
        ) {
            continue;
        }
        let name = c.skeleton.nodes.get(bone.node).map_or("", |n| n.name.as_str());
        rigid.push((b, add_part(name, parts)));
    }
    // Single pieces skinned to one of the limb's own joints (a spear weighted to the hand
    // bone), named after the limb ("Right Arm Prop").
    let limb_of = |v: u32| vertex_joint[v as usize].map(|j| part_of_joint[j]);
    let piece_limb: Vec<Option<usize>> = piece_vertices
        .iter()
        .map(|vs| {
            let limb = vs.first().and_then(|&v| limb_of(v))?;
            vs.iter().all(|&v| limb_of(v) == Some(limb)).then_some(limb)
        })
        .collect();
    // A piece whose vertices follow two joints or more bends with the limb: it is skin (an
    // arm, a sleeve), never a prop, whatever its size.
    let bends = |vs: &[u32]| {
        let first = vs.first().and_then(|&v| vertex_joint[v as usize]);
        vs.iter().any(|&v| vertex_joint[v as usize] != first)
    };
    let mut rigid_bone = vec![false; c.bones.len()];
    for &(b, _) in &rigid {
        rigid_bone[b] = true;
    }
    // A piece skinned to the joint a limb hangs from (`roots`: the limbs' own first joints,
    // not a one-joint weapon socket merged into an arm) is the limb itself (a box
    // character's one-joint arm), not something held in it.
    let on_limb_root = |vs: &[u32]| {
        vs.first()
            .and_then(|&v| vertex_joint[v as usize])
            .is_some_and(|j| roots.contains(&j))
    };
    let mut found: Vec<(usize, usize, f32)> = Vec::new();
    for (k, vs) in piece_vertices.iter().enumerate() {
        let Some(limb) = piece_limb[k] else { continue };
        if limb == 0
            || limb >= limb_parts
            || legs.contains(&limb)
            || on_limb_root(vs)
            || bends(vs)
            || vs
                .iter()
                .any(|&v| rigid_bone.get(vertex_bone[v as usize]).copied().unwrap_or(false))
        {
            continue;
        }
        let held = |v: usize| vertex_piece[v] == k;
        if far(&[k], &held, limb, part_of_joint, &mut reach_cache, &mut bones_cache) {
            found.push((k, limb, reach_cache[&(limb, k)]));
        }
    }
    // The farthest-reaching first, at most PROP_PIECES_MAX (feathers or hair cards, each a
    // piece, are no props).
    found.sort_by(|a, b| b.2.total_cmp(&a.2).then(a.0.cmp(&b.0)));
    found.truncate(PROP_PIECES_MAX);
    found.sort_by_key(|f| f.0);
    let mut part_of_piece: Vec<Option<usize>> = vec![None; pieces];
    for &(k, limb, _) in &found {
        let name = unique_name(parts, &format!("{} Prop", parts[limb].name));
        part_of_piece[k] = Some(parts.len());
        parts.push(Part {
            name,
            color: part_color(parts.len()),
        });
    }
    let triangle_part = if found.is_empty() {
        Vec::new()
    } else {
        piece.iter().map(|&k| part_of_piece[k]).collect()
    };
    (rigid, triangle_part)
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let d = b - a;
    let t = if d.length_squared() > 0.0 {
        ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + d * t)
}

/// Each triangle's piece (triangles joined by edges in the rest pose `rest`, the vertices
/// skinned at rest; UV seams welded) and the number of pieces.
fn pieces_at(c: &Character, rest: &[Vec3]) -> (Vec<usize>, usize) {
    let neighbours = neighbours_at(c, rest);
    let tris = neighbours.len();
    let mut piece = vec![usize::MAX; tris];
    let mut pieces = 0;
    for start in 0..tris {
        if piece[start] != usize::MAX {
            continue;
        }
        let mut stack = vec![start];
        piece[start] = pieces;
        while let Some(t) = stack.pop() {
            for &u in &neighbours[t] {
                let u = u as usize;
                if u < tris && piece[u] == usize::MAX {
                    piece[u] = pieces;
                    stack.push(u);
                }
            }
        }
        pieces += 1;
    }
    (piece, pieces)
}

/// Each triangle's neighbours across its edges in the rest pose (UV seams welded): pieces
/// modelled in one place and moved apart by their joints (a robot's two hands) are not joined.
fn rest_neighbours(c: &Character) -> Vec<[u32; 3]> {
    let rest = crate::animation::skin_vertices(c, &crate::animation::Pose::rest(c)).0;
    neighbours_at(c, &rest)
}

/// [`rest_neighbours`] with the rest pose's vertices already skinned (`rest`).
fn neighbours_at(c: &Character, rest: &[Vec3]) -> Vec<[u32; 3]> {
    let welded = crate::character::weld_points(rest.iter().copied());
    crate::character::triangle_neighbours(&c.indices, &welded)
}

/// Most triangles a piece of a part may have, as a share of the part's, and still be given
/// to the part around it ([`tidy_islands`]).
pub const ISLAND_SHARE: f64 = 0.005;

/// Gives each small island of a part — a piece joined by edges only to other parts' triangles,
/// on no open edge of the mesh, and holding at most [`ISLAND_SHARE`] of its part's — to the
/// part it shares most edges with; a part's largest piece, pieces that touch no other part
/// (a separate mesh: an eye, a glove) and pieces at the mesh's own edge (the open end of a
/// limb's tube) stay. Labelling triangles by skin weight leaves such islands where weights
/// cross evenly (dense meshes with smooth weights: single triangles of the torso inside an
/// arm), and each is a cut with a cap of its own and a stray piece in its part's images.
/// `neighbours`: [`crate::character::triangle_neighbours`]. Returns how many triangles moved.
pub fn tidy_islands(neighbours: &[[u32; 3]], labels: &mut [u16]) -> usize {
    tidy_islands_with(neighbours, labels, None)
}

/// Most triangles a piece of a part lying far from the rest of it may have, as a share of the
/// part's, and be given to the part around it ([`tidy_islands_with`]).
pub const FAR_ISLAND_SHARE: f64 = 0.1;
/// How far from the rest of its part (in heights) a piece lies to be given away at up to
/// [`FAR_ISLAND_SHARE`] (the generated quadruped's torso had a ring of 12 triangles on its
/// tail, 0.16 of its height from the body, which every view joined to it with a bridge).
pub const FAR_ISLAND_GAP: f32 = 0.05;

/// [`tidy_islands`], and with the triangles' rest-pose `centroids`, also pieces of up to
/// [`FAR_ISLAND_SHARE`] of their part that lie at least [`FAR_ISLAND_GAP`] of the height from
/// the rest of it (the same exclusions: a part's largest piece, separate meshes, pieces on
/// the mesh's open edge).
pub fn tidy_islands_with(neighbours: &[[u32; 3]], labels: &mut [u16], centroids: Option<&[Vec3]>) -> usize {
    let tris = labels.len().min(neighbours.len());
    let height = centroids.map_or(0.0, |c| {
        let (lo, hi) = c.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
        (hi - lo).max(0.0)
    });
    let mut moved = 0;
    // Giving an island away can leave another (an island inside an island): a few rounds.
    for _ in 0..4 {
        let parts = labels[..tris].iter().map(|&l| l as usize + 1).max().unwrap_or(0);
        let mut totals = vec![0usize; parts];
        for &l in &labels[..tris] {
            totals[l as usize] += 1;
        }
        let pieces = label_pieces(neighbours, &labels[..tris]);
        let largest = largest_pieces(&pieces, parts);
        let mut changed = false;
        for (i, (l, members)) in pieces.iter().enumerate() {
            let share = members.len() as f64 / totals[*l as usize].max(1) as f64;
            if largest[*l as usize] == Some(i) || share > FAR_ISLAND_SHARE.max(ISLAND_SHARE) {
                continue;
            }
            // Larger than a speck: only when far from the rest of its part.
            if share > ISLAND_SHARE
                && !centroids.is_some_and(|c| {
                    members.len() <= 2000
                        && height > 0.0
                        && piece_gap(c, &pieces, i, FAR_ISLAND_GAP * height) >= FAR_ISLAND_GAP * height
                })
            {
                continue;
            }
            let mut edges = vec![0usize; parts];
            let mut open = false;
            for &t in members {
                for &n in &neighbours[t as usize] {
                    let n = n as usize;
                    if n >= tris {
                        open = true;
                    } else if labels[n] != *l {
                        edges[labels[n] as usize] += 1;
                    }
                }
            }
            // On the mesh's own edge (the open end of a limb's tube under a separate body):
            // not inside anything.
            if open {
                continue;
            }
            let Some(to) = (0..parts)
                .filter(|&p| edges[p] > 0)
                .max_by(|&a, &b| edges[a].cmp(&edges[b]).then(b.cmp(&a)))
            else {
                continue;
            };
            for &t in members {
                labels[t as usize] = to as u16;
            }
            moved += members.len();
            changed = true;
        }
        if !changed {
            break;
        }
    }
    moved
}

/// Each triangle's centroid, from the vertices `positions` (the rest pose's, skinned).
pub fn triangle_centroids(c: &Character, positions: &[Vec3]) -> Vec<Vec3> {
    c.indices
        .chunks_exact(3)
        .map(|t| {
            t.iter()
                .map(|&i| positions.get(i as usize).copied().unwrap_or_default())
                .sum::<Vec3>()
                / 3.0
        })
        .collect()
}

/// How far piece `i` of `pieces` ([`label_pieces`]) lies from the other pieces of its label:
/// the least distance between their triangles' `centroids`; infinite when it is its label's
/// only piece. Stops looking once a distance under `enough` is found (and returns it).
pub fn piece_gap(centroids: &[Vec3], pieces: &[(u16, Vec<u32>)], i: usize, enough: f32) -> f32 {
    let (label, members) = &pieces[i];
    let at = |t: u32| centroids.get(t as usize).copied().unwrap_or_default();
    let mut best = f32::INFINITY;
    for (_, (_, other)) in pieces.iter().enumerate().filter(|(k, (l, _))| *k != i && l == label) {
        for &a in members {
            for &b in other {
                best = best.min(at(a).distance_squared(at(b)));
            }
            if best < enough * enough {
                return best.sqrt();
            }
        }
    }
    best.sqrt()
}

/// The pieces of every part: triangles connected by edges within one label, each with its
/// label and members (`neighbours`: [`crate::character::triangle_neighbours`]; an entry past
/// the triangles is an open edge).
pub fn label_pieces(neighbours: &[[u32; 3]], labels: &[u16]) -> Vec<(u16, Vec<u32>)> {
    let tris = labels.len().min(neighbours.len());
    let mut piece = vec![u32::MAX; tris];
    let mut pieces: Vec<(u16, Vec<u32>)> = Vec::new();
    for start in 0..tris {
        if piece[start] != u32::MAX {
            continue;
        }
        let id = pieces.len() as u32;
        let label = labels[start];
        let mut members = vec![start as u32];
        piece[start] = id;
        let mut k = 0;
        while k < members.len() {
            let t = members[k] as usize;
            k += 1;
            for &n in &neighbours[t] {
                let n = n as usize;
                if n < tris && piece[n] == u32::MAX && labels[n] == label {
                    piece[n] = id;
                    members.push(n as u32);
                }
            }
        }
        pieces.push((label, members));
    }
    pieces
}

/// Each of `parts` labels' largest piece (an index into `pieces`), `None` for a label without one.
fn largest_pieces(pieces: &[(u16, Vec<u32>)], parts: usize) -> Vec<Option<usize>> {
    let mut largest = vec![None::<usize>; parts];
    for (i, (l, m)) in pieces.iter().enumerate() {
        if let Some(best) = largest.get_mut(*l as usize)
            && best.is_none_or(|b| pieces[b].1.len() < m.len())
        {
            *best = Some(i);
        }
    }
    largest
}

/// A head turning (or nodding, tilting) by more than this against the chest in any clip is a
/// part of its own ([`auto_segment`]).
pub const HEAD_TURN_DEGREES: f32 = 20.0;

/// ... when it carries at least this share of the mesh ...
pub const HEAD_SHARE: f64 = 0.03;

/// ... and at most this (more is not a head: CesiumMan's chest is weighted to its neck).
pub const HEAD_SHARE_MAX: f64 = 0.4;

/// Largest turn (degrees) of node `top` against node `base` from the start of any clip of
/// `c` to any of 16 times through it.
fn head_turn(c: &Character, base: usize, top: usize) -> f32 {
    let mut most = 0.0f32;
    for clip in &c.clips {
        let mut first: Option<glam::Quat> = None;
        for s in 0..=16 {
            let t = clip.duration_secs * s as f32 / 16.0 * (1.0 - 1e-4);
            let pose = crate::animation::Pose::sample(c, clip, t);
            let (Some(b), Some(h)) = (pose.world_from_node.get(base), pose.world_from_node.get(top)) else {
                return 0.0;
            };
            let q = (b.inverse() * *h).to_scale_rotation_translation().1.normalize();
            if !q.is_finite() {
                continue;
            }
            match first {
                None => first = Some(q),
                Some(q0) => most = most.max(q0.angle_between(q).to_degrees()),
            }
        }
    }
    most
}

/// Most parts `moving_pieces` makes (the largest pieces keep their own; the rest join the
/// piece they hang from, or the body).
pub const MAX_PIECES: usize = 16;

/// The parts of an animated prop: a file without a skin whose animations move its mesh
/// nodes, imported as rigid bones that follow their nodes (no joint in the skeleton). Each
/// animated node carries its own part (a windmill's rotor, a car's wheels, a door): a rigid
/// piece turning in its own plane is an affine warp of its image, where drawn with the rest
/// it is not. A bone whose node is not animated goes with the nearest animated node above
/// it, else with the body (what does not move). Parts are named after their nodes. `None`
/// for anything else (a skinned character, a static file).
fn moving_pieces(c: &Character) -> Option<Segmentation> {
    let nodes = &c.skeleton.nodes;
    if c.bones.is_empty() || nodes.iter().any(|n| n.is_joint) || c.clips.iter().all(|k| k.channels.is_empty()) {
        return None;
    }
    let mut animated = vec![false; nodes.len()];
    for ch in c.clips.iter().flat_map(|k| &k.channels) {
        if let Some(a) = animated.get_mut(ch.node) {
            *a = true;
        }
    }
    // The nearest animated node at or above each node (`None`: nothing above it moves).
    let mover = |mut n: usize| -> Option<usize> {
        for _ in 0..=nodes.len() {
            if animated[n] {
                return Some(n);
            }
            n = nodes[n].parent?;
        }
        None
    };
    let bone_mover: Vec<Option<usize>> = c
        .bones
        .iter()
        .map(|b| (b.node < nodes.len()).then(|| mover(b.node)).flatten())
        .collect();
    // Triangles per mover (by their first vertex's main bone: every vertex of a rigid piece
    // follows one bone).
    let tri_mover: Vec<Option<usize>> = c
        .indices
        .chunks_exact(3)
        .map(|t| bone_mover.get(main_bone(&c.vertices[t[0] as usize])).copied().flatten())
        .collect();
    let mut count: std::collections::BTreeMap<usize, usize> = Default::default();
    for m in tri_mover.iter().flatten() {
        *count.entry(*m).or_default() += 1;
    }
    // The largest pieces keep their own part; others join the nearest kept one above them.
    let mut by_size: Vec<(usize, usize)> = count.iter().map(|(&m, &n)| (m, n)).collect();
    by_size.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let kept: Vec<usize> = by_size.iter().take(MAX_PIECES - 1).map(|x| x.0).collect();
    let kept_above = |m: usize| -> Option<usize> {
        let mut at = Some(m);
        for _ in 0..=nodes.len() {
            let n = at?;
            if kept.contains(&n) {
                return Some(n);
            }
            at = nodes[n].parent.and_then(&mover);
        }
        None
    };
    let mut parts = vec![Part {
        name: "Body".into(),
        color: PALETTE[0],
    }];
    let mut part_of: std::collections::BTreeMap<usize, u16> = Default::default();
    for &m in &kept {
        let base = pretty(&nodes[m].name);
        let base = if base.is_empty() {
            format!("Piece {}", parts.len())
        } else {
            base
        };
        let name = unique_name(&parts, &base);
        part_of.insert(m, parts.len() as u16);
        parts.push(Part {
            name,
            color: part_color(parts.len()),
        });
    }
    let mut labels: Vec<u16> = tri_mover
        .iter()
        .map(|m| {
            m.and_then(kept_above)
                .and_then(|k| part_of.get(&k).copied())
                .unwrap_or(0)
        })
        .collect();
    // Everything moves (the whole prop turns): no body.
    if !labels.contains(&0) {
        parts.remove(0);
        for l in &mut labels {
            *l -= 1;
        }
    }
    let mut seg = Segmentation { parts, labels };
    compact(&mut seg);
    Some(seg)
}

/// Smallest share of the triangles a separate piece of a morphing prop needs for a part of
/// its own ([`morphing_pieces`]).
pub const PIECE_SHARE: f64 = 0.02;

/// A prop without joints whose clips animate morph targets (bars that grow, a blob that
/// breathes, a flag; a static file's one bone) and that is made of separate pieces: a part per piece (connected in the
/// rest pose, UV seams welded) holding at least [`PIECE_SHARE`] of the triangles, the
/// largest [`MAX_PIECES`] first ("Body", then named by place, [`placed_parts`]); smaller pieces join the kept
/// piece whose bounds' centre is nearest. One polygon per view cannot follow pieces that
/// change shape on their own. `None` for characters with more than one bone, without
/// animated morphs, or of one piece.
fn morphing_pieces(c: &Character) -> Option<Segmentation> {
    if c.morphs.is_empty() || c.bones.len() > 1 || c.indices.len() < 6 {
        return None;
    }
    let rest = crate::animation::skin_vertices(c, &crate::animation::Pose::rest(c)).0;
    let (piece, pieces) = pieces_at(c, &rest);
    let tris = piece.len();
    let mut sizes = vec![0usize; pieces];
    for &k in &piece {
        sizes[k] += 1;
    }
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by(|&a, &b| sizes[b].cmp(&sizes[a]).then(a.cmp(&b)));
    let kept: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&k| sizes[k] as f64 >= PIECE_SHARE * tris as f64)
        .take(MAX_PIECES)
        .collect();
    if kept.len() < 2 {
        return None;
    }
    // Each piece's bounds centre (rest pose).
    let mut lo = vec![glam::Vec3::splat(f32::INFINITY); sizes.len()];
    let mut hi = vec![glam::Vec3::splat(f32::NEG_INFINITY); sizes.len()];
    for (t, tri) in c.indices.chunks_exact(3).enumerate() {
        for &v in tri {
            let p = rest[v as usize];
            lo[piece[t]] = lo[piece[t]].min(p);
            hi[piece[t]] = hi[piece[t]].max(p);
        }
    }
    let centre = |k: usize| (lo[k] + hi[k]) * 0.5;
    let part_of: Vec<u16> = (0..sizes.len())
        .map(|k| {
            let nearest = (0..kept.len())
                .min_by(|&a, &b| {
                    let (da, db) = (centre(kept[a]).distance(centre(k)), centre(kept[b]).distance(centre(k)));
                    da.total_cmp(&db).then(a.cmp(&b))
                })
                .unwrap_or(0);
            kept.iter().position(|&x| x == k).unwrap_or(nearest) as u16
        })
        .collect();
    let labels: Vec<u16> = piece.iter().map(|&k| part_of[k]).collect();
    let parts = placed_parts(c, &rest, &labels, kept.len());
    let mut seg = Segmentation { parts, labels };
    compact(&mut seg);
    Some(seg)
}

/// Most motion clusters [`morphing_motion_parts`] cuts a one-piece morphing prop into.
pub const MOTION_PARTS_MAX: usize = 8;

/// Most parts [`morphing_motion_parts`] keeps once clusters are split into connected pieces
/// (a quadruped: body, head and neck, tail, four legs).
pub const MOTION_PIECES_MAX: usize = 10;

/// Triangles tried as the next centre by [`morphing_motion_parts`]: this many of the worst
/// fitted, and as many spread evenly.
const SEED_CANDIDATES: usize = 32;

/// Feature entries the cut of a candidate centre is measured on.
const SEED_ENTRIES: usize = 4_000_000;

/// How far apart (mean squared Frobenius distance per sampled pose) a triangle's rotations may
/// be from its part's for [`morphing_motion_parts`] to stop cutting: `8 sin²(θ/2)` for two
/// rotations θ apart, so 0.09 is about 12°.
pub const MOTION_RESIDUAL: f64 = 0.09;

/// Poses [`morphing_motion_parts`] samples, over all clips together.
const MOTION_SAMPLES: usize = 32;

/// At most this many rotation entries are held for [`morphing_motion_parts`] (fewer poses on a
/// dense mesh): 96 MB of `f32`.
const MOTION_FEATURES_MAX: usize = 24_000_000;

/// A prop without joints, in one piece, whose clips move it by morph targets (a bird flapping
/// its wings, a galloping horse: animations exported as blend shapes): parts that each turn as
/// one. A Polypostor part is one warped image; a wing sweeping over the body cannot be one
/// image with it. Each triangle's rotation from the rest pose (its edge and normal frame) at
/// poses sampled over every clip is one feature vector; a weighted k-means (by rest area;
/// the next centre at the candidate triangle whose rotations cut the residual most, of the
/// worst-fitted and an even spread, [`SEED_CANDIDATES`]) adds clusters until the triangles turn
/// within about 12° of their cluster's rotations on average ([`MOTION_RESIDUAL`]) or there are
/// [`MOTION_PARTS_MAX`]. Clusters under [`PIECE_SHARE`] of the area join their nearest centre;
/// then every connected piece of a cluster holding [`PIECE_SHARE`] of the area is a part (two
/// legs swinging alike are two parts), at most [`MOTION_PIECES_MAX`], largest first, and the
/// smaller pieces grow into the parts around them (an island touching none joins the part
/// whose centre is nearest). The largest part is "Body". `None` where that leaves one part (a
/// blob that breathes, a cube that grows), for characters with joints and for props without
/// animated morphs.
fn morphing_motion_parts(c: &Character) -> Option<Segmentation> {
    use glam::Mat3;
    if c.morphs.is_empty() || c.bones.len() > 1 || c.indices.len() < 6 {
        return None;
    }
    let clips: Vec<&crate::character::Clip> = c
        .clips
        .iter()
        .filter(|k| !k.morph_channels.is_empty() && k.duration_secs.is_finite() && k.duration_secs > 0.0)
        .collect();
    if clips.is_empty() {
        return None;
    }
    let tris = c.indices.len() / 3;
    let per_clip = MOTION_SAMPLES.div_ceil(clips.len()).max(2);
    let mut times: Vec<(usize, f32)> = clips
        .iter()
        .enumerate()
        .flat_map(|(k, clip)| (0..per_clip).map(move |i| (k, clip.duration_secs * i as f32 / per_clip as f32)))
        .collect();
    let most = (MOTION_FEATURES_MAX / (9 * tris)).clamp(2, MOTION_SAMPLES);
    if times.len() > most {
        let n = times.len();
        times = (0..most).map(|i| times[i * n / most]).collect();
    }
    let samples = times.len();
    let dim = 9 * samples;
    let frame = |p: &[Vec3], tri: &[u32]| -> Option<(Mat3, f32)> {
        let at = |i: u32| p.get(i as usize).copied();
        let (a, b, d) = (at(tri[0])?, at(tri[1])?, at(tri[2])?);
        let e1 = b - a;
        let n = e1.cross(d - a);
        let area = 0.5 * n.length();
        if !(area > 0.0 && area.is_finite() && e1.length_squared() > 0.0) {
            return None;
        }
        let (u, w) = (e1.normalize(), n.normalize());
        Some((Mat3::from_cols(u, w.cross(u), w), area))
    };
    let rest = crate::animation::skin_vertices(c, &crate::animation::Pose::rest(c)).0;
    let rest_frames: Vec<Option<(Mat3, f32)>> = c.indices.chunks_exact(3).map(|t| frame(&rest, t)).collect();
    let weight: Vec<f64> = rest_frames.iter().map(|f| f.map_or(0.0, |f| f.1 as f64)).collect();
    let total: f64 = weight.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut features = vec![0.0f32; tris * dim];
    for (s, &(k, time)) in times.iter().enumerate() {
        let pose = crate::animation::Pose::sample(c, clips[k], time);
        let p = crate::animation::skin_vertices(c, &pose).0;
        for (t, tri) in c.indices.chunks_exact(3).enumerate() {
            let r = match (rest_frames[t], frame(&p, tri)) {
                (Some((r0, _)), Some((r1, _))) => r1 * r0.transpose(),
                _ => Mat3::IDENTITY,
            };
            features[t * dim + 9 * s..t * dim + 9 * s + 9].copy_from_slice(&r.to_cols_array());
        }
    }
    let feature = |t: usize| &features[t * dim..(t + 1) * dim];
    let distance = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum::<f64>();
    let mut centres: Vec<Vec<f32>> = Vec::new();
    let mut labels = vec![0u16; tris];
    let mut dist = vec![0.0f64; tris];
    // Weighted means of the triangles of each label (a centre without triangles stays).
    let update = |centres: &mut Vec<Vec<f32>>, labels: &[u16]| {
        let mut sums = vec![vec![0.0f64; dim]; centres.len()];
        let mut weights = vec![0.0f64; centres.len()];
        for t in 0..tris {
            let l = labels[t] as usize;
            weights[l] += weight[t];
            for (s, x) in sums[l].iter_mut().zip(feature(t)) {
                *s += weight[t] * *x as f64;
            }
        }
        for (l, centre) in centres.iter_mut().enumerate() {
            if weights[l] > 0.0 {
                *centre = sums[l].iter().map(|s| (s / weights[l]) as f32).collect();
            }
        }
    };
    let assign = |centres: &[Vec<f32>], labels: &mut [u16], dist: &mut [f64], allowed: &dyn Fn(usize) -> bool| {
        for t in 0..tris {
            let f = feature(t);
            let (best, d) = (0..centres.len())
                .filter(|&l| allowed(l))
                .map(|l| (l, distance(f, &centres[l])))
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                .unwrap_or((0, 0.0));
            labels[t] = best as u16;
            dist[t] = d;
        }
    };
    centres.push(vec![0.0; dim]);
    update(&mut centres, &labels);
    assign(&centres, &mut labels, &mut dist, &|_| true);
    let residual = |dist: &[f64]| (0..tris).map(|t| weight[t] * dist[t]).sum::<f64>() / total / samples as f64;
    while residual(&dist) > MOTION_RESIDUAL && centres.len() < MOTION_PARTS_MAX {
        // The next centre: of the triangles their parts fit worst (by weight) and an even
        // spread of the others, the one whose rotations as a centre would cut the residual
        // most (the worst-fit triangle alone is often a sliver turning on its own, whose part
        // is then dropped as too small and the limbs stay in the body).
        let mut candidates: Vec<usize> = (0..tris).collect();
        candidates.sort_by(|&a, &b| (weight[b] * dist[b]).total_cmp(&(weight[a] * dist[a])).then(a.cmp(&b)));
        candidates.truncate(SEED_CANDIDATES);
        candidates.extend((0..tris).step_by(tris.div_ceil(SEED_CANDIDATES).max(1)));
        candidates.sort_unstable();
        candidates.dedup();
        // The cut is measured on an even sample of the triangles (a few million entries).
        let stride = (tris * dim).div_ceil(SEED_ENTRIES).max(1);
        let cut = |c: usize| -> f64 {
            let f = feature(c);
            (0..tris)
                .step_by(stride)
                .map(|t| weight[t] * (dist[t] - distance(feature(t), f)).max(0.0))
                .sum()
        };
        let seed = candidates
            .iter()
            .map(|&c| (c, cut(c)))
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
            .map_or(0, |(c, _)| c);
        centres.push(feature(seed).to_vec());
        for _ in 0..12 {
            let before = labels.clone();
            assign(&centres, &mut labels, &mut dist, &|_| true);
            update(&mut centres, &labels);
            if labels == before {
                break;
            }
        }
    }
    if centres.len() < 2 {
        return None;
    }
    // Parts too small for a part of their own join their nearest centre.
    let mut area = vec![0.0f64; centres.len()];
    for t in 0..tris {
        area[labels[t] as usize] += weight[t];
    }
    let kept: Vec<bool> = area.iter().map(|&a| a >= PIECE_SHARE * total).collect();
    assign(&centres, &mut labels, &mut dist, &|l| kept[l]);
    // Each connected piece of a part holding at least PIECE_SHARE of the area is a part of its
    // own (a galloping horse's front legs turn alike but are two limbs; one polygon cannot
    // hold both), the largest MOTION_PIECES_MAX; the other pieces grow into the parts around
    // them (islands touching none join the part whose centre is nearest).
    let neighbours = rest_neighbours(c);
    let pieces = label_pieces(&neighbours, &labels);
    let piece_area: Vec<f64> = pieces
        .iter()
        .map(|(_, m)| m.iter().map(|&t| weight[t as usize]).sum())
        .collect();
    let mut order: Vec<usize> = (0..pieces.len()).collect();
    order.sort_by(|&a, &b| piece_area[b].total_cmp(&piece_area[a]).then(a.cmp(&b)));
    let kept: Vec<usize> = order
        .into_iter()
        .filter(|&i| piece_area[i] >= PIECE_SHARE * total)
        .take(MOTION_PIECES_MAX)
        .collect();
    if kept.len() < 2 {
        return None;
    }
    let mut part = vec![u16::MAX; tris];
    let mut queue = std::collections::VecDeque::new();
    for (rank, &i) in kept.iter().enumerate() {
        for &t in &pieces[i].1 {
            part[t as usize] = rank as u16;
            queue.push_back(t as usize);
        }
    }
    while let Some(t) = queue.pop_front() {
        for &n in &neighbours[t] {
            let n = n as usize;
            if n < tris && part[n] == u16::MAX {
                part[n] = part[t];
                queue.push_back(n);
            }
        }
    }
    if part.contains(&u16::MAX) {
        let centre_of = |members: &[u32]| {
            let (mut sum, mut w) = (Vec3::ZERO, 0.0f32);
            for &t in members {
                let tri = &c.indices[3 * t as usize..3 * t as usize + 3];
                let m = tri
                    .iter()
                    .map(|&v| rest.get(v as usize).copied().unwrap_or(Vec3::ZERO))
                    .sum::<Vec3>()
                    / 3.0;
                sum += m;
                w += 1.0;
            }
            sum / w.max(1.0)
        };
        let centres: Vec<Vec3> = kept.iter().map(|&i| centre_of(&pieces[i].1)).collect();
        for (_, members) in label_pieces(&neighbours, &part) {
            if members.first().is_none_or(|&t| part[t as usize] != u16::MAX) {
                continue;
            }
            let at = centre_of(&members);
            let nearest = (0..centres.len())
                .min_by(|&a, &b| {
                    centres[a]
                        .distance(at)
                        .total_cmp(&centres[b].distance(at))
                        .then(a.cmp(&b))
                })
                .unwrap_or(0);
            for &t in &members {
                part[t as usize] = nearest as u16;
            }
        }
    }
    let parts = placed_parts(c, &rest, &part, kept.len());
    Some(Segmentation { parts, labels: part })
}

/// Least offset from the body's centre, as a share of the prop's size along an axis, that
/// [`placed_parts`] names (a part nearer the middle along every axis is "Middle").
pub const PLACE_NAME_SHARE: f32 = 0.15;

/// Names for `count` parts cut from a prop without joints (`rest`: its rest-pose vertex
/// positions), in palette order: the largest (part 0) "Body", every other by where its rest-pose centre (the mean of its triangles'
/// centres) lies from the body's, along glTF's axes (the front is +z, the prop's left +x, up
/// +y): "Front Left Lower", "Rear", "Upper", … — words along each axis where the offset is at
/// least [`PLACE_NAME_SHARE`] of the prop's size along it, "Middle" where none is; repeats
/// numbered ("Front Left Lower 2"). A horse's legs read as such in the editor's list, not
/// as "Part 7".
fn placed_parts(c: &Character, rest: &[Vec3], labels: &[u16], count: usize) -> Vec<Part> {
    let mut sum = vec![Vec3::ZERO; count];
    let mut n = vec![0u32; count];
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (tri, &l) in c.indices.chunks_exact(3).zip(labels) {
        let corners: Option<Vec<Vec3>> = tri.iter().map(|&v| rest.get(v as usize).copied()).collect();
        let Some(corners) = corners else { continue };
        for &q in &corners {
            lo = lo.min(q);
            hi = hi.max(q);
        }
        if let Some(k) = sum.get_mut(l as usize) {
            *k += (corners[0] + corners[1] + corners[2]) / 3.0;
            n[l as usize] += 1;
        }
    }
    let centre = |k: usize| sum[k] / n[k].max(1) as f32;
    let size = (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
    let mut parts: Vec<Part> = Vec::with_capacity(count);
    for k in 0..count {
        let name = if k == 0 {
            "Body".to_string()
        } else {
            let d = (centre(k) - centre(0)) / size;
            let words: Vec<&str> = [(d.z, "Front", "Rear"), (d.x, "Left", "Right"), (d.y, "Upper", "Lower")]
                .into_iter()
                .filter(|(o, _, _)| o.abs() >= PLACE_NAME_SHARE)
                .map(|(o, plus, minus)| if o > 0.0 { plus } else { minus })
                .collect();
            let base = if words.is_empty() {
                "Middle".to_string()
            } else {
                words.join(" ")
            };
            unique_name(&parts, &base)
        };
        parts.push(Part {
            name,
            color: part_color(k),
        });
    }
    parts
}

/// The bone carrying most of a vertex's weight.
fn main_bone(v: &crate::character::Vertex) -> usize {
    let k = (0..4)
        .max_by(|&a, &b| v.weights[a].total_cmp(&v.weights[b]))
        .unwrap_or(0);
    v.bones[k] as usize
}

/// `base`, or `base 2`, `base 3`, … : the first no part of `parts` has.
fn unique_name(parts: &[Part], base: &str) -> String {
    let mut name = base.to_string();
    let mut n = 2;
    while parts.iter().any(|p| p.name == name) {
        name = format!("{base} {n}");
        n += 1;
    }
    name
}

fn pretty(base: &str) -> String {
    base.split(['_', '.', ' ', '-'])
        .map(|t| t.trim_end_matches(|c: char| c.is_ascii_digit()))
        .filter(|t| {
            // Rig prefixes ("b_", "c_", "DEF", "mixamorig") and numbering say nothing.
            t.len() > 1
                && !matches!(
                    t.to_ascii_lowercase().as_str(),
                    "mixamorig" | "joint" | "bone" | "def" | "jnt" | "ctrl" | "org" | "mch"
                )
        })
        .map(|t| {
            let mut c = t.chars();
            c.next()
                .map(|f| f.to_uppercase().collect::<String>() + c.as_str())
                .unwrap_or_default()
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Removes parts without triangles and renumbers the labels.
pub fn compact(seg: &mut Segmentation) {
    let sizes = seg.part_sizes();
    let mut map = vec![u16::MAX; seg.parts.len()];
    let mut parts = Vec::new();
    for (p, part) in seg.parts.iter().enumerate() {
        if sizes[p] > 0 || p == 0 {
            map[p] = parts.len() as u16;
            parts.push(part.clone());
        }
    }
    for l in &mut seg.labels {
        *l = map.get(*l as usize).copied().filter(|&m| m != u16::MAX).unwrap_or(0);
    }
    seg.parts = parts;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every part a segmentation may hold gets its own colour, clearly apart from every other
    /// (no two within 40 of each other in the largest channel difference).
    #[test]
    fn part_colours_are_distinct_up_to_the_part_limit() {
        let colors: Vec<[u8; 3]> = (0..crate::limits::MAX_PARTS).map(part_color).collect();
        for (i, a) in colors.iter().enumerate() {
            for b in &colors[..i] {
                let d = (0..3).map(|c| (a[c] as i32 - b[c] as i32).abs()).max().unwrap();
                assert!(d >= 40, "{a:?} and {b:?} ({colors:?})");
            }
        }
    }

    /// A prop whose clips animate morph targets and that is made of separate pieces (three
    /// grids far apart, and a single stray triangle beside the second) gets a part per piece,
    /// the stray triangle with the piece nearest it; without animated morphs it stays one part
    /// (a static prop draws its key image whole). Independent answer: the pieces as built.
    #[test]
    fn a_morphing_prop_gets_a_part_per_piece() {
        use crate::character::{Bone, MorphTarget, Node, Skeleton, Transform};
        let piece = grid(5, false);
        let mut c = Character {
            skeleton: Skeleton {
                nodes: vec![Node {
                    name: "root".into(),
                    parent: None,
                    rest: Transform::IDENTITY,
                    is_joint: true,
                }],
            },
            bones: vec![Bone {
                node: 0,
                inverse_bind: glam::Mat4::IDENTITY,
            }],
            ..Default::default()
        };
        for dx in [0.0, 20.0, 40.0] {
            let base = c.vertices.len() as u32;
            c.vertices
                .extend(piece.vertices.iter().map(|v| crate::character::Vertex {
                    position: v.position + Vec3::X * dx,
                    ..*v
                }));
            c.indices.extend(piece.indices.iter().map(|i| i + base));
        }
        let per_piece = piece.indices.len() / 3;
        let base = c.vertices.len() as u32;
        for p in [
            Vec3::new(26.0, 2.0, 0.0),
            Vec3::new(26.5, 2.0, 0.0),
            Vec3::new(26.0, 2.5, 0.0),
        ] {
            c.vertices.push(crate::character::Vertex {
                position: p,
                ..piece.vertices[0]
            });
        }
        c.indices.extend([base, base + 1, base + 2]);
        assert_eq!(auto_segment(&c).parts.len(), 1, "static: one part");
        c.morphs = vec![MorphTarget {
            name: "grow".into(),
            vertices: vec![0],
            positions: vec![Vec3::Z],
            normals: vec![Vec3::ZERO],
            ..Default::default()
        }];
        let seg = auto_segment(&c);
        assert_eq!(seg.parts.len(), 3, "{:?}", seg.parts);
        // Named by place: the other two lie towards +x (the prop's left) of the body.
        let mut names: Vec<&str> = seg.parts.iter().map(|p| p.name.as_str()).collect();
        names.sort_unstable();
        assert_eq!(names, ["Body", "Left", "Left 2"]);
        let label = |t: usize| seg.labels[t];
        for k in 0..3 {
            let first = label(k * per_piece);
            assert!(
                (k * per_piece..(k + 1) * per_piece).all(|t| label(t) == first),
                "piece {k} is one part"
            );
        }
        assert!(
            label(0) != label(per_piece)
                && label(per_piece) != label(2 * per_piece)
                && label(0) != label(2 * per_piece)
        );
        assert_eq!(
            label(3 * per_piece),
            label(per_piece),
            "the stray triangle joins the piece beside it"
        );
        // One bone more (a rig): the joint chains decide, not the pieces.
        let mut rigged = c.clone();
        rigged.bones.push(rigged.bones[0]);
        assert!(morphing_pieces(&rigged).is_none());
    }

    /// A prop in one piece whose clip moves it by morph targets — a flap hinged on a plate,
    /// swinging up and down (each target the flap turned by another angle) — gets two parts
    /// split at the hinge, the same whatever the prop's size, place and orientation; a prop
    /// whose targets only grow it (no triangle turns) stays one part. Independent answer: the
    /// flap's triangles as built (quads right of the hinge column).
    #[test]
    fn a_morphing_prop_in_one_piece_gets_a_part_per_turning_region() {
        let n = 10;
        let hinge = 6.0;
        let flap = |p: Vec3, swing: glam::Quat, _: f32| {
            if p.x > hinge {
                Vec3::new(hinge, 0.0, 0.0) + swing * (p - Vec3::new(hinge, 0.0, 0.0))
            } else {
                p
            }
        };
        // Quad (x, y) holds triangles 2 (y n + x) and + 1: the flap is the quads right of the hinge.
        let on_flap = |t: usize| (t / 2) % n >= hinge as usize;
        for (scale, turn, shift) in rig_placements() {
            let c = morphing_grid(n, scale, turn, shift, &flap);
            let seg = auto_segment(&c);
            assert_eq!(seg.parts.len(), 2, "scale {scale}: {:?}", seg.parts);
            assert_eq!(seg.parts[0].name, "Body");
            if scale == 1.0 {
                // The flap lies towards +x of the plate: the prop's left.
                assert_eq!(seg.parts[1].name, "Left");
            }
            let tris = c.indices.len() / 3;
            let flap_label = seg.labels[2 * (n - 1)];
            for t in 0..tris {
                assert_eq!(seg.labels[t] == flap_label, on_flap(t), "scale {scale}: triangle {t}");
            }
            // The plate (6 of 10 columns) is the larger part.
            assert_ne!(flap_label, 0, "scale {scale}");
        }
        let grows = morphing_grid(n, 1.0, glam::Quat::IDENTITY, Vec3::ZERO, &|p, _, deg| {
            p * (1.0 + deg.abs() / 100.0)
        });
        assert_eq!(
            auto_segment(&grows).parts.len(),
            1,
            "growing turns no triangle: one part"
        );
    }

    /// Two flaps on either side of a plate swinging alike (a galloping horse's front legs, a
    /// bird's wings beating together) turn the same way at every pose, so one motion cluster
    /// holds both; they are two limbs apart, and get a part each. Independent answer: the
    /// flaps' quads as built (three columns each side of a four-column plate), whatever the
    /// prop's size, place and orientation.
    #[test]
    fn limbs_that_swing_alike_get_a_part_each() {
        let n = 10;
        let (left, right) = (3.0, 7.0);
        let flaps = |p: Vec3, swing: glam::Quat, _: f32| {
            let hinge = |h: f32| Vec3::new(h, 0.0, 0.0) + swing * (p - Vec3::new(h, 0.0, 0.0));
            if p.x < left {
                hinge(left)
            } else if p.x > right {
                hinge(right)
            } else {
                p
            }
        };
        let column = |t: usize| (t / 2) % n;
        for (scale, turn, shift) in rig_placements() {
            let c = morphing_grid(n, scale, turn, shift, &flaps);
            let seg = auto_segment(&c);
            assert_eq!(seg.parts.len(), 3, "scale {scale}: {:?}", seg.parts);
            let (l, r) = (seg.labels[0], seg.labels[2 * (n - 1)]);
            assert_ne!(l, r, "scale {scale}: the two flaps share a part");
            if scale == 1.0 {
                // Named by place (−x is the prop's right), not numbered.
                assert_eq!(seg.parts[l as usize].name, "Right");
                assert_eq!(seg.parts[r as usize].name, "Left");
            }
            for t in 0..c.indices.len() / 3 {
                let want = match column(t) {
                    x if x < left as usize => l,
                    x if x >= right as usize => r,
                    _ => 0,
                };
                assert_eq!(seg.labels[t], want, "scale {scale}: triangle {t}");
            }
        }
    }

    /// Placements of a test rig: as built, huge and turned and moved, tiny and turned.
    fn rig_placements() -> [(f32, glam::Quat, Vec3); 3] {
        [
            (1.0, glam::Quat::IDENTITY, Vec3::ZERO),
            (
                100.0,
                glam::Quat::from_rotation_x(1.1) * glam::Quat::from_rotation_z(0.4),
                Vec3::new(3.0, -40.0, 7.0),
            ),
            (0.001, glam::Quat::from_rotation_y(2.0), Vec3::new(0.0, 0.002, 0.0)),
        ]
    }

    /// The grid of [`grid`] (`n`×`n`, no seam) as a one-bone prop with three morph targets
    /// and a clip that plays them in turn: target `k` moves each rest point `p` to
    /// `moved(p, swing, deg)` for `deg` −50°, 0°, 50° (`swing`: that turn about y), the whole
    /// placed by `scale`, `turn` and `shift`.
    fn morphing_grid(
        n: usize,
        scale: f32,
        turn: glam::Quat,
        shift: Vec3,
        moved: &dyn Fn(Vec3, glam::Quat, f32) -> Vec3,
    ) -> Character {
        use crate::character::{Bone, Clip, Interpolation, MorphChannel, MorphTarget, Node, Skeleton, Transform};
        let mut c = grid(n, false);
        c.skeleton = Skeleton {
            nodes: vec![Node {
                name: "root".into(),
                parent: None,
                rest: Transform::IDENTITY,
                is_joint: true,
            }],
        };
        c.bones = vec![Bone {
            node: 0,
            inverse_bind: glam::Mat4::IDENTITY,
        }];
        let place = |p: Vec3| turn * (p * scale) + shift;
        let rest: Vec<Vec3> = c.vertices.iter().map(|v| v.position).collect();
        for v in &mut c.vertices {
            v.position = place(v.position);
        }
        c.morphs = [-50.0f32, 0.0, 50.0]
            .iter()
            .map(|&deg| {
                let swing = glam::Quat::from_rotation_y(deg.to_radians());
                MorphTarget {
                    name: format!("swing {deg}"),
                    rest_weight: 0.0,
                    normals: vec![Vec3::ZERO; rest.len()],
                    vertices: (0..rest.len() as u32).collect(),
                    positions: rest.iter().map(|&p| place(moved(p, swing, deg)) - place(p)).collect(),
                }
            })
            .collect();
        c.clips = vec![Clip {
            name: "flap".into(),
            duration_secs: 1.0,
            channels: Vec::new(),
            in_place_velocity: Vec3::ZERO,
            morph_channels: vec![MorphChannel {
                targets: vec![0, 1, 2],
                interpolation: Interpolation::Linear,
                times: vec![0.0, 0.25, 0.5, 0.75, 1.0],
                values: vec![
                    1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0,
                ],
            }],
        }];
        c
    }

    /// A flat grid of `n`×`n` unit quads (two triangles each, quad `(x, y)` holding triangles
    /// `2 (y n + x)` and `+ 1`); `seam`: the vertices on column `n / 4` split as a UV seam
    /// splits them (the quads right of it use copies at the same positions).
    fn grid(n: usize, seam: bool) -> Character {
        let vertex = |x: usize, y: usize| crate::character::Vertex {
            position: Vec3::new(x as f32, y as f32, 0.0),
            normal: Vec3::Z,
            uv: [0.0; 2],
            color: [1.0; 4],
            bones: [0; 4],
            weights: [1.0, 0.0, 0.0, 0.0],
        };
        let side = n + 1;
        let mut vertices: Vec<_> = (0..side * side).map(|i| vertex(i % side, i / side)).collect();
        let copy: Vec<u32> = (0..side)
            .map(|y| {
                vertices.push(vertex(n / 4, y));
                (vertices.len() - 1) as u32
            })
            .collect();
        let id = |x: usize, y: usize, right: bool| -> u32 {
            if seam && right && x == n / 4 {
                copy[y]
            } else {
                (y * side + x) as u32
            }
        };
        let mut indices = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let right = x >= n / 4;
                let (a, b, c, d) = (
                    id(x, y, right),
                    id(x + 1, y, right),
                    id(x + 1, y + 1, right),
                    id(x, y + 1, right),
                );
                indices.extend([a, b, c, a, c, d]);
            }
        }
        Character {
            vertices,
            indices,
            ..Default::default()
        }
    }

    /// Small pieces of one part inside another go to the part around them; large ones, the
    /// largest piece of each part, pieces touching no other part and pieces on the mesh's
    /// open edge stay (labels built by hand; with and without a UV seam through an island).
    #[test]
    fn small_islands_join_the_part_around_them() {
        let n = 48;
        for seam in [false, true] {
            let mut c = grid(n, seam);
            // A quad of its own, far away, touching nothing: part 1.
            let base = c.vertices.len() as u32;
            for (x, y) in [(100, 0), (101, 0), (101, 1), (100, 1)] {
                let mut v = c.vertices[0].clone();
                v.position = Vec3::new(x as f32, y as f32, 0.0);
                c.vertices.push(v);
            }
            c.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
            let quad = |x: usize, y: usize| [2 * (y * n + x), 2 * (y * n + x) + 1];
            // Left half 0, right half 1.
            let mut labels: Vec<u16> = (0..2 * n * n).map(|t| u16::from((t / 2) % n >= n / 2)).collect();
            labels.extend([1, 1]);
            let mut want = labels.clone();
            // One triangle of part 1 inside the left half.
            labels[quad(5, 5)[0]] = 1;
            // A 2 × 2 block of part 1 across column n / 4 (the seam): 8 triangles.
            for y in 10..12 {
                for x in n / 4 - 1..n / 4 + 1 {
                    for t in quad(x, y) {
                        labels[t] = 1;
                    }
                }
            }
            // One triangle of part 1 on the grid's outer edge (an open edge of the mesh): stays.
            labels[quad(0, 30)[1]] = 1;
            want[quad(0, 30)[1]] = 1;
            // A 5 × 4 block of part 0 inside the right half: 40 triangles, over 0.5 % of part 0.
            for y in 20..24 {
                for x in 30..35 {
                    for t in quad(x, y) {
                        labels[t] = 0;
                        want[t] = 0;
                    }
                }
            }
            let neighbours = crate::character::triangle_neighbours(&c.indices, &crate::character::weld(&c));
            // Across the seam the quads are still neighbours (welded).
            assert_eq!(
                neighbours[quad(n / 4 - 1, 11)[0]][1] as usize,
                quad(n / 4, 11)[1],
                "seam {seam}"
            );
            let moved = tidy_islands(&neighbours, &mut labels);
            assert_eq!(labels, want, "seam {seam}");
            assert_eq!(moved, 1 + 8, "seam {seam}");
        }
    }

    /// On the default character, no piece of a part touching another part is left that
    /// the rule would give away.
    #[test]
    fn automatic_parts_leave_no_small_islands() {
        for c in [crate::default_character::generate()] {
            let seg = auto_segment(&c);
            let mut labels = seg.labels.clone();
            assert_eq!(tidy_islands(&rest_neighbours(&c), &mut labels), 0);
        }
    }

    #[test]
    fn side_tokens_are_found_in_common_naming_schemes() {
        for (a, b) in [
            ("LeftUpperArm", "RightUpperArm"),
            ("mixamorig:LeftLeg", "mixamorig:RightLeg"),
            ("leg_joint_L_1", "leg_joint_R_1"),
            ("UpperArm.L", "UpperArm.R"),
            ("Shoulder_L", "Shoulder_R"),
        ] {
            let (na, sa) = side_free_name(a);
            let (nb, sb) = side_free_name(b);
            assert_eq!(na, nb, "{a} / {b}");
            assert!(sa.is_some() && sb.is_some() && sa != sb, "{a} / {b}");
        }
        assert_eq!(side_free_name("Spine").1, None);
    }

    #[test]
    fn default_humanoid_gets_the_papers_five_parts() {
        let c = crate::default_character::generate();
        let s = auto_segment(&c);
        let mut names: Vec<&str> = s.parts.iter().map(|p| p.name.as_str()).collect();
        names.sort();
        assert_eq!(
            names,
            ["Left Arm", "Left Leg", "Right Arm", "Right Leg", "Torso"],
            "{names:?}"
        );
        assert_eq!(s.labels.len(), c.triangle_count());
        assert!(s.part_sizes().iter().all(|&n| n > 100), "{:?}", s.part_sizes());
        // The head belongs to the torso; the hands to the arms.
        let head = c.skeleton.find("Head").unwrap() as u16;
        let hand = c.skeleton.find("LeftHand").unwrap() as u16;
        let label_of_bone = |b: u16| {
            let t = c
                .indices
                .chunks_exact(3)
                .position(|t| {
                    t.iter()
                        .all(|&v| c.vertices[v as usize].bones[0] == b && c.vertices[v as usize].weights[0] > 0.99)
                })
                .unwrap();
            s.parts[s.labels[t] as usize].name.clone()
        };
        assert_eq!(label_of_bone(head), "Torso");
        assert_eq!(label_of_bone(hand), "Left Arm");
    }

    #[test]
    fn a_head_that_turns_on_its_own_is_a_part_of_its_own() {
        use crate::character::{Channel, ChannelValues, Interpolation};
        let mut c = crate::default_character::generate();
        let neck = c.skeleton.find("Neck").unwrap();
        let head = c.skeleton.find("Head").unwrap();
        // The default's head moves with its chest (5 parts, above); turned 60° about the
        // vertical through the Wave, it becomes a part: the neck and head, nothing else.
        let wave = c.find_clip("Wave").unwrap();
        let d = c.clips[wave].duration_secs;
        let rest = c.skeleton.nodes[head].rest.rotation;
        let clip = &mut c.clips[wave];
        clip.channels
            .retain(|ch| !(ch.node == head && matches!(ch.values, ChannelValues::Rotation(_))));
        clip.channels.push(Channel {
            node: head,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 0.5 * d, d],
            values: ChannelValues::Rotation(vec![rest, glam::Quat::from_rotation_y(60f32.to_radians()) * rest, rest]),
        });
        let s = auto_segment(&c);
        let names: Vec<&str> = s.parts.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(s.parts.len(), 6, "{names:?}");
        let h = s.parts.iter().position(|p| p.name == "Head").unwrap() as u16;
        let plain = auto_segment(&crate::default_character::generate());
        for (t, tri) in c.indices.chunks_exact(3).enumerate() {
            let v = &c.vertices[tri[0] as usize];
            let node = c.bones[main_bone(v)].node;
            let on_head = node == head || node == neck;
            if s.labels[t] == h {
                // Only what the torso had, and mostly the head's own triangles.
                assert_eq!(plain.parts[plain.labels[t] as usize].name, "Torso");
            } else if on_head && v.weights.iter().copied().fold(0.0, f32::max) > 0.99 {
                panic!(
                    "triangle {t} on the head's joints is in {}",
                    names[s.labels[t] as usize]
                );
            }
            if s.labels[t] != h {
                assert_eq!(
                    s.parts[s.labels[t] as usize].name,
                    plain.parts[plain.labels[t] as usize].name
                );
            }
        }
        // A turn under the threshold keeps the paper's five parts.
        if let Some(ChannelValues::Rotation(q)) = c.clips[wave].channels.last_mut().map(|ch| &mut ch.values) {
            q[1] = glam::Quat::from_rotation_y(10f32.to_radians()) * rest;
        }
        assert_eq!(auto_segment(&c).parts.len(), 5);
    }

    #[test]
    fn segmentation_is_invariant_to_a_rigid_move_of_the_rig() {
        let c = crate::default_character::generate();
        let mut moved = c.clone();
        moved.skeleton.nodes[0].rest.translation += Vec3::new(3.0, 0.0, -2.0);
        assert_eq!(auto_segment(&c), auto_segment(&moved));
    }

    /// Units do not enter the segmentation: the rig scaled by a hundred-thousandth (a
    /// character 0.02 mm tall; an absolute floor on its height once took it for one lying
    /// flat and named its arms as legs) or a hundred thousand gets the same parts.
    #[test]
    fn segmentation_is_invariant_to_the_rig_s_scale() {
        let c = crate::default_character::generate();
        let plain = auto_segment(&c);
        for k in [1e-5f32, 1e-3, 1e3, 1e5] {
            let mut scaled = c.clone();
            scaled.skeleton.nodes[0].rest.scale *= k;
            let extent = crate::character::bounds(
                crate::animation::skin_vertices(&scaled, &crate::animation::Pose::rest(&scaled)).0,
            );
            assert!(
                ((extent.1 - extent.0).max_element() / k - 1.6).abs() < 0.5,
                "scale {k}: {extent:?}"
            );
            assert_eq!(auto_segment(&scaled), plain, "scale {k}");
        }
    }

    /// A character of boxes, one per joint (each box a separate piece skinned wholly to its
    /// joint, as box and voxel characters are made): `(name, parent, offset from the parent,
    /// box min, box max)`, the box relative to its joint.
    fn box_rig(joints: &[(&str, Option<usize>, [f32; 3], [f32; 3], [f32; 3])]) -> Character {
        use crate::character::{Bone, Material, Node, Skeleton, Submesh, Transform, Vertex};
        let mut world = Vec::new();
        let mut nodes = Vec::new();
        let (mut vertices, mut indices) = (Vec::new(), Vec::new());
        for (k, &(name, parent, offset, lo, hi)) in joints.iter().enumerate() {
            let at = parent.map_or(Vec3::ZERO, |p| world[p]) + Vec3::from(offset);
            world.push(at);
            nodes.push(Node {
                name: name.into(),
                parent,
                rest: Transform {
                    translation: Vec3::from(offset),
                    ..Transform::default()
                },
                is_joint: true,
            });
            let first = vertices.len() as u32;
            for corner in 0..8 {
                let pick = |bit: u32, axis: usize| if corner & bit != 0 { hi[axis] } else { lo[axis] };
                vertices.push(Vertex {
                    position: at + Vec3::new(pick(1, 0), pick(2, 1), pick(4, 2)),
                    normal: Vec3::Y,
                    uv: [0.0, 0.0],
                    color: [1.0; 4],
                    bones: [k as u16, 0, 0, 0],
                    weights: [1.0, 0.0, 0.0, 0.0],
                });
            }
            for f in [
                [0, 2, 3, 1],
                [4, 5, 7, 6],
                [0, 1, 5, 4],
                [2, 6, 7, 3],
                [0, 4, 6, 2],
                [1, 3, 7, 5],
            ] {
                indices.extend([f[0], f[1], f[2], f[0], f[2], f[3]].map(|i: u32| first + i));
            }
        }
        let bones = world
            .iter()
            .enumerate()
            .map(|(node, &w)| Bone {
                node,
                inverse_bind: glam::Mat4::from_translation(-w),
            })
            .collect();
        Character {
            name: "Boxes".into(),
            submeshes: vec![Submesh {
                first_index: 0,
                index_count: indices.len() as u32,
                material: 0,
            }],
            vertices,
            indices,
            materials: vec![Material {
                name: "m".into(),
                base_color_factor: [1.0; 4],
                base_color_texture: None,
                double_sided: false,
                alpha_cutoff: 0.0,
                wrap: Default::default(),
            }],
            textures: Vec::new(),
            skeleton: Skeleton { nodes },
            bones,
            clips: Vec::new(),
            warnings: Vec::new(),
            up_axis: Default::default(),
            morphs: Vec::new(),
        }
    }

    type BoxJoint = (&'static str, Option<usize>, [f32; 3], [f32; 3], [f32; 3]);

    /// A mirrored pair of [`box_rig`] joints: the first at `at`, the second mirrored in x.
    fn pair(
        names: [&'static str; 2],
        parents: [Option<usize>; 2],
        at: [f32; 3],
        lo: [f32; 3],
        hi: [f32; 3],
    ) -> [BoxJoint; 2] {
        [
            (names[0], parents[0], at, lo, hi),
            (names[1], parents[1], [-at[0], at[1], at[2]], lo, hi),
        ]
    }

    /// Box characters (a piece per joint): with one joint per limb, each limb is a part
    /// (they all joined the torso: one part, limbs warped across the body); with two-joint
    /// arms and no hand joint, the forearm's box is the arm's, not a prop of its own ("Fore
    /// Arm", unsided). Every triangle goes to the part named after its limb.
    #[test]
    fn box_characters_get_a_part_per_limb() {
        let (trunk, one) = box_humanoid();
        let part_of = |s: &Segmentation, box_index: usize| -> String {
            let labels = &s.labels[12 * box_index..12 * box_index + 12];
            assert!(labels.iter().all(|&l| l == labels[0]), "box {box_index}: {labels:?}");
            s.parts[labels[0] as usize].name.clone()
        };
        let c = box_rig(&[&trunk[..], &one[..]].concat());
        let s = auto_segment(&c);
        let got: Vec<String> = (0..7).map(|b| part_of(&s, b)).collect();
        assert_eq!(
            got,
            [
                "Torso",
                "Torso",
                "Torso",
                "Left Leg",
                "Right Leg",
                "Left Arm",
                "Right Arm"
            ],
            "{:?}",
            s.parts
        );
        // Two joints per limb, the arms without hands.
        let two = [
            pair(
                ["LeftUpLeg", "RightUpLeg"],
                [Some(0); 2],
                [0.12, -0.1, 0.0],
                [-0.08, -0.45, -0.08],
                [0.08, 0.0, 0.08],
            ),
            pair(
                ["LeftArm", "RightArm"],
                [Some(1); 2],
                [0.3, 0.45, 0.0],
                [-0.06, -0.32, -0.06],
                [0.06, 0.0, 0.06],
            ),
            pair(
                ["LeftLeg", "RightLeg"],
                [Some(3), Some(4)],
                [0.0, -0.45, 0.0],
                [-0.07, -0.45, -0.07],
                [0.07, 0.0, 0.07],
            ),
            pair(
                ["LeftForeArm", "RightForeArm"],
                [Some(5), Some(6)],
                [0.0, -0.32, 0.0],
                [-0.05, -0.33, -0.05],
                [0.05, 0.0, 0.05],
            ),
        ]
        .concat();
        let c = box_rig(&[&trunk[..], &two[..]].concat());
        let s = auto_segment(&c);
        let got: Vec<String> = (0..11).map(|b| part_of(&s, b)).collect();
        assert_eq!(
            got,
            [
                "Torso",
                "Torso",
                "Torso",
                "Left Leg",
                "Right Leg",
                "Left Arm",
                "Right Arm",
                "Left Leg",
                "Right Leg",
                "Left Arm",
                "Right Arm"
            ],
            "{:?}",
            s.parts
        );
        assert_eq!(s.parts.len(), 5);
        // Eyes: a mirrored pair of one joint each under the head, each with a small mesh of
        // its own holding more than 2 % of the vertices: no limbs, the head's.
        let mut with_eyes = [&trunk[..], &two[..]].concat();
        with_eyes.push(("LeftEye", Some(2), [0.05, 0.15, 0.1], [-0.015; 3], [0.015; 3]));
        with_eyes.push(("RightEye", Some(2), [-0.05, 0.15, 0.1], [-0.015; 3], [0.015; 3]));
        let s = auto_segment(&box_rig(&with_eyes));
        let got: Vec<String> = (0..13).map(|b| part_of(&s, b)).collect();
        assert_eq!(got[11..], ["Torso", "Torso"], "{:?}", s.parts);
        assert_eq!(s.parts.len(), 5, "{:?}", s.parts);
        // A control joint carrying no mesh, far off, changes nothing.
        let mut with_ik = [&trunk[..], &one[..]].concat();
        with_ik.push(("LeftArmIK", Some(0), [3.0, 0.0, 0.0], [0.0; 3], [0.0; 3]));
        with_ik.push(("RightArmIK", Some(0), [-3.0, 0.0, 0.0], [0.0; 3], [0.0; 3]));
        let mut c = box_rig(&with_ik);
        // The control joints' boxes are points: drop them (no mesh).
        c.indices.truncate(7 * 36);
        c.submeshes[0].index_count = c.indices.len() as u32;
        c.vertices.truncate(7 * 8);
        let s = auto_segment(&c);
        let got: Vec<String> = (0..7).map(|b| part_of(&s, b)).collect();
        assert_eq!(
            got[3..],
            ["Left Leg", "Right Leg", "Left Arm", "Right Arm"],
            "{:?}",
            s.parts
        );
    }

    /// A [`box_rig`] humanoid: hips, spine and head, and a one-joint leg and arm each side.
    fn box_humanoid() -> ([BoxJoint; 3], Vec<BoxJoint>) {
        let trunk = [
            ("Hips", None, [0.0, 1.0, 0.0], [-0.2, -0.1, -0.12], [0.2, 0.15, 0.12]),
            (
                "Spine",
                Some(0),
                [0.0, 0.15, 0.0],
                [-0.22, 0.0, -0.12],
                [0.22, 0.5, 0.12],
            ),
            (
                "Head",
                Some(1),
                [0.0, 0.55, 0.0],
                [-0.12, 0.0, -0.12],
                [0.12, 0.25, 0.12],
            ),
        ];
        let limbs: Vec<BoxJoint> = [
            pair(
                ["LeftLeg", "RightLeg"],
                [Some(0); 2],
                [0.12, -0.1, 0.0],
                [-0.08, -0.9, -0.08],
                [0.08, 0.0, 0.08],
            ),
            pair(
                ["LeftArm", "RightArm"],
                [Some(1); 2],
                [0.3, 0.45, 0.0],
                [-0.06, -0.65, -0.06],
                [0.06, 0.0, 0.06],
            ),
        ]
        .concat();
        (trunk, limbs)
    }

    /// Appends a chain of `n` joints carrying no mesh (as rigs carry tail, cape or IK chains
    /// with nothing skinned to them yet) under node `under`, each `step` further back.
    fn add_empty_chain(c: &mut Character, under: usize, name: &str, n: usize, step: f32) {
        use crate::character::{Node, Transform};
        let mut parent = under;
        for k in 0..n {
            c.skeleton.nodes.push(Node {
                name: format!("{name}{k:02}"),
                parent: Some(parent),
                rest: Transform {
                    translation: Vec3::new(0.0, 0.0, -step),
                    ..Transform::default()
                },
                is_joint: true,
            });
            parent = c.skeleton.nodes.len() - 1;
            let world = c.skeleton.rest_world()[parent];
            c.bones.push(crate::character::Bone {
                node: parent,
                inverse_bind: world.inverse(),
            });
        }
    }

    /// Chains of joints that carry no skin weight change nothing: a box rig and the default
    /// humanoid with an empty chain of 3 or 10 joints (named "TailBone…", 1 cm to 10 cm apart) under
    /// the hips or the chest get the same parts on the same triangles. (The empty chain became
    /// the trunk and took both arms into a "Spine" part; three empty "Tail" joints turned a
    /// box rig's legs into "Tail Prop"s.)
    #[test]
    fn joints_without_weight_change_no_part() {
        let (trunk, limbs) = box_humanoid();
        let boxes = box_rig(&[&trunk[..], &limbs[..]].concat());
        let default = crate::default_character::generate();
        let hips = default.skeleton.find("Hips").unwrap();
        let chest = default
            .skeleton
            .find("Chest")
            .or_else(|| default.skeleton.find("Spine"))
            .unwrap();
        for (c, places) in [(&boxes, [0, 1]), (&default, [hips, chest])] {
            let plain = auto_segment(c);
            for under in places {
                for (n, step) in [(3, 0.01), (10, 0.1)] {
                    let mut with = c.clone();
                    add_empty_chain(&mut with, under, "TailBone", n, step);
                    let got = auto_segment(&with);
                    assert_eq!(got, plain, "{} with {n} empty joints under node {under}", c.name);
                    // The same with a trace of weight on the chain's last joint (a control
                    // bone an exporter left 0.001 on, on one vertex).
                    let last = with.bones.len() - 1;
                    let v = &mut with.vertices[0];
                    let k = (0..4).min_by(|&a, &b| v.weights[a].total_cmp(&v.weights[b])).unwrap();
                    v.bones[k] = last as u16;
                    v.weights[k] = 0.001;
                    let got = auto_segment(&with);
                    assert_eq!(got.parts, plain.parts, "{} with a trace on the chain", c.name);
                }
            }
        }
    }

    /// A box rig with one finely subdivided piece on the hips (a chest plate of 5,000
    /// triangles): each one-joint limb holds 0.3 % of the vertices but much of the surface,
    /// and stay parts of their own (they all joined the torso: one part for the whole body).
    #[test]
    fn a_dense_piece_does_not_swallow_box_limbs() {
        let (trunk, limbs) = box_humanoid();
        let plain = box_rig(&[&trunk[..], &limbs[..]].concat());
        let mut dense = plain.clone();
        let n = 50u32;
        let first = dense.vertices.len() as u32;
        for y in 0..=n {
            for x in 0..=n {
                let mut v = dense.vertices[0].clone();
                v.position = Vec3::new(-0.15 + 0.3 * x as f32 / n as f32, 1.0 + 0.3 * y as f32 / n as f32, 0.14);
                v.bones = [0; 4];
                v.weights = [1.0, 0.0, 0.0, 0.0];
                dense.vertices.push(v);
            }
        }
        for y in 0..n {
            for x in 0..n {
                let i = first + y * (n + 1) + x;
                dense.indices.extend([i, i + 1, i + n + 2, i, i + n + 2, i + n + 1]);
            }
        }
        dense.submeshes[0].index_count = dense.indices.len() as u32;
        // Each limb's 8 vertices: far under SINGLE_JOINT_LIMB_SHARE of the whole.
        assert!(8.0 < 0.5 * SINGLE_JOINT_LIMB_SHARE * dense.vertices.len() as f64);
        let (a, b) = (auto_segment(&plain), auto_segment(&dense));
        assert_eq!(a.parts, b.parts);
        assert_eq!(a.labels[..], b.labels[..a.labels.len()]);
        assert!(
            b.labels[a.labels.len()..]
                .iter()
                .all(|&l| b.parts[l as usize].name == "Torso")
        );
        assert_eq!(b.parts.len(), 5, "{:?}", b.parts);
    }

    /// A spear held in the default's right hand (a separate piece skinned to a joint of its
    /// own below the hand, as game rigs carry weapons) is a part of its own, named after the
    /// joint; the rest keeps its five parts; a small piece on the same kind of joint (a
    /// bracelet) stays with the arm; the same two bound rigidly to a node under the hand
    /// (no skin) likewise; the rig's scale changes nothing.
    #[test]
    fn a_spear_in_a_hand_is_a_part_of_its_own() {
        use crate::character::{Bone, Node, Transform, Vertex};
        // `joint`: skinned to a joint of its own; else bound rigidly to a node that is no
        // joint (a mesh parented to the hand, as the `knight` variants carry their props).
        let with_piece = |name: &str, half: Vec3, offset: Vec3, joint: bool| {
            let mut c = crate::default_character::generate();
            let hand = c.skeleton.find("RightHand").unwrap();
            c.skeleton.nodes.push(Node {
                name: name.into(),
                parent: Some(hand),
                rest: Transform {
                    translation: Vec3::new(0.0, -0.05, 0.0),
                    ..Transform::default()
                },
                is_joint: joint,
            });
            let node = c.skeleton.nodes.len() - 1;
            let world = c.skeleton.rest_world()[node];
            let (inverse_bind, centre) = if joint {
                (world.inverse(), world.transform_point3(offset))
            } else {
                (glam::Mat4::IDENTITY, offset)
            };
            c.bones.push(Bone { node, inverse_bind });
            let bone = (c.bones.len() - 1) as u16;
            let first = c.vertices.len() as u32;
            for k in 0..8 {
                let s = |bit: u32| if k & bit != 0 { 1.0 } else { -1.0 };
                c.vertices.push(Vertex {
                    position: centre + half * Vec3::new(s(1), s(2), s(4)),
                    normal: Vec3::Y,
                    uv: [0.0, 0.0],
                    color: [1.0; 4],
                    bones: [bone, 0, 0, 0],
                    weights: [1.0, 0.0, 0.0, 0.0],
                });
            }
            let faces: [[u32; 4]; 6] = [
                [0, 2, 3, 1],
                [4, 5, 7, 6],
                [0, 1, 5, 4],
                [2, 6, 7, 3],
                [0, 4, 6, 2],
                [1, 3, 7, 5],
            ];
            for f in faces {
                c.indices
                    .extend([f[0], f[1], f[2], f[0], f[2], f[3]].map(|i| first + i));
            }
            if let Some(last) = c.submeshes.last_mut() {
                last.index_count += 36;
            }
            c
        };
        let names = |s: &Segmentation| {
            let mut n: Vec<String> = s.parts.iter().map(|p| p.name.clone()).collect();
            n.sort();
            n
        };
        let spear = with_piece(
            "WeaponSlot",
            Vec3::new(0.015, 0.015, 0.7),
            Vec3::new(0.0, 0.0, 0.4),
            true,
        );
        let s = auto_segment(&spear);
        assert_eq!(
            names(&s),
            ["Left Arm", "Left Leg", "Right Arm", "Right Leg", "Torso", "Weapon"],
            "{:?}",
            names(&s)
        );
        let weapon = s.parts.iter().position(|p| p.name == "Weapon").unwrap() as u16;
        let tris = spear.triangle_count();
        assert!(
            s.labels[tris - 12..].iter().all(|&l| l == weapon),
            "{:?}",
            &s.labels[tris - 12..]
        );
        assert_eq!(s.part_sizes()[weapon as usize], 12);
        let bracelet = with_piece("WeaponSlot", Vec3::splat(0.04), Vec3::ZERO, true);
        assert_eq!(names(&auto_segment(&bracelet)).len(), 5);
        let sword = with_piece("Sword", Vec3::new(0.015, 0.015, 0.7), Vec3::new(0.0, 0.0, 0.4), false);
        let rigid = auto_segment(&sword);
        assert_eq!(rigid.parts.last().map(|p| p.name.as_str()), Some("Sword"));
        assert_eq!(rigid.labels, s.labels);
        let bead = with_piece("Bead", Vec3::splat(0.04), Vec3::ZERO, false);
        assert_eq!(names(&auto_segment(&bead)).len(), 5);
        // The spear weighted to the hand bone itself (no joint of its own): a part named
        // after the arm, of the spear's triangles.
        let mut on_hand = spear.clone();
        let hand_bone = on_hand
            .bones
            .iter()
            .position(|b| b.node == on_hand.skeleton.find("RightHand").unwrap())
            .unwrap() as u16;
        let n = on_hand.vertices.len();
        for v in &mut on_hand.vertices[n - 8..] {
            v.bones[0] = hand_bone;
        }
        let held = auto_segment(&on_hand);
        assert_eq!(held.parts.last().map(|p| p.name.as_str()), Some("Right Arm Prop"));
        assert_eq!(held.labels, s.labels);
        // A detailed spear (one piece of 101 rings, more vertices than the hand and the arm's
        // own pieces) weighted to the hand bone: a part too.
        let mut detailed = crate::default_character::generate();
        let hand = detailed.skeleton.find("RightHand").unwrap();
        let hand_bone = detailed.bones.iter().position(|b| b.node == hand).unwrap() as u16;
        let at = detailed.skeleton.rest_world()[hand].transform_point3(Vec3::new(0.0, -0.05, 0.0));
        let tris = detailed.triangle_count();
        let first = detailed.vertices.len() as u32;
        let rings = 101u32;
        for r in 0..rings {
            let z = -0.3 + 1.4 * r as f32 / (rings - 1) as f32;
            for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                detailed.vertices.push(Vertex {
                    position: at + Vec3::new(0.015 * x, 0.015 * y, z),
                    normal: Vec3::Y,
                    uv: [0.0, 0.0],
                    color: [1.0; 4],
                    bones: [hand_bone, 0, 0, 0],
                    weights: [1.0, 0.0, 0.0, 0.0],
                });
            }
        }
        for r in 0..rings - 1 {
            for q in 0..4 {
                let (a, b) = (first + 4 * r + q, first + 4 * r + (q + 1) % 4);
                detailed.indices.extend([a, b, b + 4, a, b + 4, a + 4]);
            }
        }
        let added = (detailed.indices.len() / 3 - tris) as u32;
        if let Some(last) = detailed.submeshes.last_mut() {
            last.index_count += 3 * added;
        }
        let seg = auto_segment(&detailed);
        let prop = seg
            .parts
            .iter()
            .position(|p| p.name == "Right Arm Prop")
            .expect("a prop part") as u16;
        assert!(seg.labels[tris..].iter().all(|&l| l == prop));
        assert_eq!(seg.part_sizes()[prop as usize], added as usize);
        assert_eq!(seg.parts.len(), 6);
        // Two thousand loose triangles weighted to the hand, far from it (feathers, hair
        // cards): at most PROP_PIECES_MAX parts of them.
        let mut loose = crate::default_character::generate();
        let hand = loose.skeleton.find("RightHand").unwrap();
        let bone = loose.bones.iter().position(|b| b.node == hand).unwrap() as u16;
        let at = loose.skeleton.rest_world()[hand].transform_point3(Vec3::ZERO);
        for k in 0..2000 {
            let first = loose.vertices.len() as u32;
            let p = at + Vec3::new(0.3 + 0.0005 * k as f32, 0.0, 0.4);
            for d in [Vec3::ZERO, Vec3::X * 0.01, Vec3::Y * 0.01] {
                loose.vertices.push(Vertex {
                    position: p + d,
                    normal: Vec3::Z,
                    uv: [0.0, 0.0],
                    color: [1.0; 4],
                    bones: [bone, 0, 0, 0],
                    weights: [1.0, 0.0, 0.0, 0.0],
                });
            }
            loose.indices.extend([first, first + 1, first + 2]);
        }
        if let Some(last) = loose.submeshes.last_mut() {
            last.index_count += 6000;
        }
        let seg = auto_segment(&loose);
        let props = seg
            .parts
            .iter()
            .filter(|p| p.name.starts_with("Right Arm Prop"))
            .count();
        assert_eq!(props, PROP_PIECES_MAX, "{:?}", names(&seg));
        assert_eq!(seg.parts.len(), 5 + PROP_PIECES_MAX);
        for k in [1e-3f32, 1e3] {
            let mut scaled = spear.clone();
            scaled.skeleton.nodes[0].rest.scale *= k;
            assert_eq!(auto_segment(&scaled), s, "scale {k}");
        }
    }
}
