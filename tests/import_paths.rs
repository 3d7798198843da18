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
    // A still pose keyed once per channel at 2.5 s: a clip of no length (one baked frame),
    // not a 2.5-second hold of 25 identical frames; the pose is the key's.
    let mut pose = c.clone();
    pose.clips.truncate(1);
    for ch in &mut pose.clips[0].channels {
        let x = ch.interpolation == Interpolation::CubicSpline;
        let keep = if x { 3 } else { 1 };
        ch.times.truncate(1);
        ch.times[0] = 2.5;
        match &mut ch.values {
            ChannelValues::Translation(v) | ChannelValues::Scale(v) => v.truncate(keep),
            ChannelValues::Rotation(v) => v.truncate(keep),
        }
    }
    pose.clips[0].duration_secs = 2.5;
    let back = import_slice(&write_glb(&pose).unwrap(), None, "x").unwrap();
    assert_eq!(back.clips[0].duration_secs, 0.0, "{:?}", back.warnings);
    let (p, _) = skin_vertices(&back, &Pose::sample(&back, &back.clips[0], 0.0));
    let (q, _) = skin_vertices(&pose, &Pose::sample(&pose, &pose.clips[0], 2.5));
    let off = p.iter().zip(&q).map(|(x, y)| (*x - *y).length()).fold(0.0f32, f32::max);
    assert!(off < 1e-4, "the still pose moved by {off}");
}

/// A glTF written by our own writer (external buffer) whose JSON and buffer a test edits
/// before importing it: `add` appends an accessor of f32 or u16 rows and returns its index.
struct Editable {
    json: serde_json::Value,
    bin: Vec<u8>,
}

impl Editable {
    fn of(c: &polypostor::Character) -> Self {
        let files = write_gltf(c, &BufferStorage::External("b.bin".into())).unwrap();
        Editable {
            json: serde_json::from_str(&files.json).unwrap(),
            bin: files.bin.unwrap(),
        }
    }

    /// `kind`: the glTF component type, 5126 (f32), 5123 (u16) or 5125 (u32).
    fn add(&mut self, rows: &[[f32; 4]], width: usize, kind: u32) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let start = self.bin.len();
        for r in rows {
            for &x in &r[..width] {
                match kind {
                    5123 => self.bin.extend_from_slice(&(x as u16).to_le_bytes()),
                    5125 => self.bin.extend_from_slice(&(x as u32).to_le_bytes()),
                    _ => self.bin.extend_from_slice(&x.to_le_bytes()),
                }
            }
        }
        let views = self.json["bufferViews"].as_array_mut().unwrap();
        views.push(serde_json::json!({"buffer": 0, "byteOffset": start, "byteLength": self.bin.len() - start}));
        let view = views.len() - 1;
        let typ = ["", "SCALAR", "VEC2", "VEC3", "VEC4"][width];
        let mut acc = serde_json::json!({
            "bufferView": view,
            "componentType": kind,
            "count": rows.len(),
            "type": typ,
        });
        if width == 3 && kind == 5126 {
            let lo: Vec<f32> = (0..3)
                .map(|k| rows.iter().map(|r| r[k]).fold(f32::MAX, f32::min))
                .collect();
            let hi: Vec<f32> = (0..3)
                .map(|k| rows.iter().map(|r| r[k]).fold(f32::MIN, f32::max))
                .collect();
            acc["min"] = serde_json::json!(lo);
            acc["max"] = serde_json::json!(hi);
        }
        let accs = self.json["accessors"].as_array_mut().unwrap();
        accs.push(acc);
        accs.len() - 1
    }

    fn import(self, name: &str) -> polypostor::Character {
        self.try_import(name).unwrap()
    }

    /// The import's error as text, empty when it succeeds.
    fn import_error(self, name: &str) -> String {
        self.try_import(name).err().map(|e| e.to_string()).unwrap_or_default()
    }

    fn try_import(self, name: &str) -> Result<polypostor::Character, polypostor::import::ImportError> {
        self.try_import_with(name, Default::default())
    }

    fn try_import_with(
        mut self,
        name: &str,
        options: polypostor::ImportOptions,
    ) -> Result<polypostor::Character, polypostor::import::ImportError> {
        self.json["buffers"][0]["byteLength"] = serde_json::json!(self.bin.len());
        let dir = common::temp_dir(name);
        std::fs::write(dir.join("b.bin"), &self.bin).unwrap();
        std::fs::write(dir.join("c.gltf"), serde_json::to_string(&self.json).unwrap()).unwrap();
        let c = polypostor::import_path_with(&dir.join("c.gltf"), options);
        std::fs::remove_dir_all(dir).unwrap();
        c
    }

    fn primitives(&mut self) -> Vec<&mut serde_json::Value> {
        let meshes = self.json["meshes"].as_array_mut().unwrap();
        meshes
            .iter_mut()
            .flat_map(|m| m["primitives"].as_array_mut().unwrap().iter_mut())
            .collect()
    }
}

/// Skinned positions of `c` at six times of each clip.
fn poses_of(c: &polypostor::Character) -> Vec<Vec<Vec3>> {
    let mut out = Vec::new();
    for clip in &c.clips {
        for k in 0..6 {
            let t = clip.duration_secs * k as f32 / 6.0;
            out.push(skin_vertices(c, &Pose::sample(c, clip, t)).0);
        }
    }
    out
}

fn largest_offset(a: &[Vec<Vec3>], b: &[Vec<Vec3>]) -> f32 {
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (*x - *y).length()))
        .fold(0.0, f32::max)
}

/// Eight influences per vertex (JOINTS_1/WEIGHTS_1, as exporters write for dense rigs): the
/// importer had left the second set out, so a vertex whose strongest joint sat there lost it.
/// Here every vertex's strongest joint is moved to the second set and its second joint is
/// split half and half between both sets (the same joint named twice). Independent answer:
/// the same character with its four influences in one set.
#[test]
fn eight_influences_per_vertex_keep_the_strongest_four() {
    let c = small_character();
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    let mut e = Editable::of(&c);
    let (mut j0, mut w0, mut j1, mut w1) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut split_some = false;
    for v in &c.vertices {
        let order = {
            let mut o = [0usize, 1, 2, 3];
            o.sort_by(|&a, &b| v.weights[b].total_cmp(&v.weights[a]));
            o
        };
        let (top, second) = (order[0], order[1]);
        let j = v.bones.map(|b| b as f32);
        let mut a = v.weights;
        a[top] = 0.0;
        let mut jb = [j[top], j[top], j[top], j[top]];
        let mut wb = [v.weights[top], 0.0, 0.0, 0.0];
        if v.weights[second] > 0.0 {
            a[second] *= 0.5;
            jb[1] = j[second];
            wb[1] = v.weights[second] * 0.5;
            split_some = true;
        }
        j0.push(j);
        w0.push(a);
        j1.push(jb);
        w1.push(wb);
    }
    assert!(split_some);
    let ids = [
        e.add(&j0, 4, 5123),
        e.add(&w0, 4, 5126),
        e.add(&j1, 4, 5123),
        e.add(&w1, 4, 5126),
    ];
    for p in e.primitives() {
        let at = &mut p["attributes"];
        for (name, id) in ["JOINTS_0", "WEIGHTS_0", "JOINTS_1", "WEIGHTS_1"].iter().zip(ids) {
            at[*name] = serde_json::json!(id);
        }
    }
    let eight = e.import("eight_influences");
    let off = largest_offset(&poses_of(&eight), &poses_of(&plain));
    assert!(off < 1e-4, "largest offset {off}");
    assert!(
        eight.warnings.iter().all(|w| !w.contains("influences")),
        "nothing was left out, nothing to say: {:?}",
        eight.warnings
    );
}

/// A morph target on by default (`mesh.weights`, and a node's own weights over the mesh's)
/// is the shape the file shows: it was ignored, so a character shaped by a body slider came
/// in as its base mesh. Independent answer: the base positions moved by weight × delta, then
/// skinned.
#[test]
fn morph_targets_shape_the_character_at_their_default_weights() {
    let c = small_character();
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    let n = c.vertices.len();
    // Two targets: up by 0.1 and out along x by 0.2 (per unit weight).
    let up: Vec<[f32; 4]> = vec![[0.0, 0.1, 0.0, 0.0]; n];
    let out: Vec<[f32; 4]> = c
        .vertices
        .iter()
        .map(|v| [0.2 * v.position.x.signum(), 0.0, 0.0, 0.0])
        .collect();
    for (weights_on, expect) in [("mesh", [0.5f32, 0.0]), ("node", [0.25, 1.0])] {
        let mut e = Editable::of(&c);
        let (a, b) = (e.add(&up, 3, 5126), e.add(&out, 3, 5126));
        for p in e.primitives() {
            p["targets"] = serde_json::json!([{"POSITION": a}, {"POSITION": b}]);
        }
        for m in e.json["meshes"].as_array_mut().unwrap() {
            m["weights"] = serde_json::json!([0.5, 0.0]);
        }
        if weights_on == "node" {
            for node in e.json["nodes"].as_array_mut().unwrap() {
                if node.get("mesh").is_some() {
                    node["weights"] = serde_json::json!(expect);
                }
            }
        }
        let shaped = e.import(&format!("morph_{weights_on}"));
        let mut moved = plain.clone();
        for (v, d) in moved.vertices.iter_mut().zip(&out) {
            v.position += Vec3::new(0.0, 0.1 * expect[0], 0.0) + Vec3::new(d[0], 0.0, 0.0) * expect[1];
        }
        let off = largest_offset(&poses_of(&shaped), &poses_of(&moved));
        assert!(off < 1e-4, "{weights_on}: largest offset {off}");
        let base = largest_offset(&poses_of(&shaped), &poses_of(&plain));
        assert!(base > 0.04, "{weights_on}: the targets moved nothing ({base})");
        assert!(
            shaped.warnings.iter().any(|w| w.contains("morph target")),
            "{:?}",
            shaped.warnings
        );
    }
}

/// Adds to the first clip a weights channel on the first mesh node: keys at 0 and 0.5 s
/// (`values`: one row per key, or three per key for CUBICSPLINE).
fn animate_weights(e: &mut Editable, values: &[[f32; 4]], interpolation: &str) {
    let node = e.json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|nd| nd.get("mesh").is_some())
        .unwrap();
    let times = e.add(&[[0.0; 4], [0.5, 0.0, 0.0, 0.0]], 1, 5126);
    let out = e.add(values, 1, 5126);
    let anim = &mut e.json["animations"][0];
    let samplers = anim["samplers"].as_array_mut().unwrap();
    samplers.push(serde_json::json!({"input": times, "output": out, "interpolation": interpolation}));
    let sampler = samplers.len() - 1;
    anim["channels"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"sampler": sampler, "target": {"node": node, "path": "weights"}}));
}

/// Morph weight channels are played: the shape at every time is the file's base mesh moved
/// by the sampled weight × the target's offsets, then skinned. A channel that holds the
/// default weights throughout (as RobotExpressive's face does in all 14 clips) keeps no
/// morph target at all (the character, its bakes and packs are as without the channel).
/// Independent answer: the same file without targets, its vertices moved by the weight the
/// glTF interpolation formulas give at that time (linear, step, cubic Hermite), skinned.
#[test]
fn morph_weight_channels_are_played() {
    let c = small_character();
    assert!(!c.clips.is_empty());
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    let n = c.vertices.len();
    let up: Vec<[f32; 4]> = vec![[0.0, 0.1, 0.0, 0.0]; n];
    let hermite = |p0: f32, m0: f32, p1: f32, m1: f32, u: f32| {
        let (u2, u3) = (u * u, u * u * u);
        p0 * (2.0 * u3 - 3.0 * u2 + 1.0) + m0 * (u3 - 2.0 * u2 + u) + p1 * (-2.0 * u3 + 3.0 * u2) + m1 * (u3 - u2)
    };
    // Keys at 0 and 0.5 s; the weight expected at time t.
    type Expect = Box<dyn Fn(f32) -> f32>;
    let cases: [(&str, &str, Vec<[f32; 4]>, bool, Expect); 5] = [
        (
            "still",
            "LINEAR",
            vec![[0.5, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0]],
            false,
            Box::new(|_| 0.5),
        ),
        (
            "moving",
            "LINEAR",
            vec![[0.5, 0.0, 0.0, 0.0], [0.8, 0.0, 0.0, 0.0]],
            true,
            Box::new(|t: f32| 0.5 + 0.3 * (t / 0.5).min(1.0)),
        ),
        (
            "step",
            "STEP",
            vec![[0.5, 0.0, 0.0, 0.0], [1.5, 0.0, 0.0, 0.0]],
            true,
            Box::new(|t: f32| if t < 0.5 { 0.5 } else { 1.5 }),
        ),
        // Cubic: in-tangent, value, out-tangent per key.
        (
            "cubic_flat",
            "CUBICSPLINE",
            vec![
                [0.0; 4],
                [0.5, 0.0, 0.0, 0.0],
                [0.0; 4],
                [0.0; 4],
                [0.5, 0.0, 0.0, 0.0],
                [0.0; 4],
            ],
            false,
            Box::new(|_| 0.5),
        ),
        (
            "cubic_bent",
            "CUBICSPLINE",
            vec![
                [0.0; 4],
                [0.5, 0.0, 0.0, 0.0],
                [0.3, 0.0, 0.0, 0.0],
                [0.0; 4],
                [0.5, 0.0, 0.0, 0.0],
                [0.0; 4],
            ],
            true,
            Box::new(move |t: f32| {
                if t < 0.5 {
                    hermite(0.5, 0.3 * 0.5, 0.5, 0.0, t / 0.5)
                } else {
                    0.5
                }
            }),
        ),
    ];
    for (what, interpolation, values, moves, expect) in cases {
        let mut e = Editable::of(&c);
        let a = e.add(&up, 3, 5126);
        for p in e.primitives() {
            p["targets"] = serde_json::json!([{"POSITION": a}]);
        }
        for m in e.json["meshes"].as_array_mut().unwrap() {
            m["weights"] = serde_json::json!([0.5]);
        }
        animate_weights(&mut e, &values, interpolation);
        let imported = e.import(&format!("weights_{what}"));
        assert!(
            imported.warnings.iter().all(|w| !w.contains("not played")),
            "{what}: {:?}",
            imported.warnings
        );
        assert_eq!(!imported.morphs.is_empty(), moves, "{what}: morph targets kept");
        let clip = &imported.clips[0];
        assert!(clip.duration_secs > 0.5, "{what}: the clip runs past the last key");
        let mut largest_change = 0.0f32;
        for k in 0..12 {
            let t = clip.duration_secs * k as f32 / 12.0;
            let got = skin_vertices(&imported, &Pose::sample(&imported, clip, t)).0;
            let mut moved = plain.clone();
            for v in &mut moved.vertices {
                v.position.y += 0.1 * expect(t);
            }
            let want = skin_vertices(&moved, &Pose::sample(&moved, &moved.clips[0], t)).0;
            let off = largest_offset(&[got.clone()], &[want]);
            assert!(off < 1e-4, "{what} at {t:.3} s: largest offset {off}");
            let mut rest = plain.clone();
            for v in &mut rest.vertices {
                v.position.y += 0.05;
            }
            let still = skin_vertices(&rest, &Pose::sample(&rest, &rest.clips[0], t)).0;
            largest_change = largest_change.max(largest_offset(&[got], &[still]));
        }
        assert_eq!(
            largest_change > 1e-3,
            moves,
            "{what}: the shape moved by {largest_change}"
        );
    }
}

/// KHR_texture_transform (scale, rotation, offset and its own texture coordinate set) places
/// the base colour texture: it had been ignored, and the texture's `texCoord` too, so such a
/// character came in wrongly textured. Here TEXCOORD_1 holds coordinates that the transform
/// maps back onto the character's own and TEXCOORD_0 is all zero. Independent answer: the
/// example of the extension's specification (offset [0, 1], a quarter turn, scale ½ reads
/// the image's lower left quadrant) and the plain file's coordinates.
#[test]
fn a_texture_transform_places_the_base_colour_texture() {
    let c = small_character();
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    let (scale, rot, off) = ([2.0f32, 0.5], 0.3f32, [0.1f32, -0.2]);
    let (s, co) = rot.sin_cos();
    let undone: Vec<[f32; 4]> = c
        .vertices
        .iter()
        .map(|v| {
            let (x, y) = (v.uv[0] - off[0], v.uv[1] - off[1]);
            [(co * x - s * y) / scale[0], (s * x + co * y) / scale[1], 0.0, 0.0]
        })
        .collect();
    let mut e = Editable::of(&c);
    let zero = e.add(&vec![[0.0; 4]; c.vertices.len()], 2, 5126);
    let one = e.add(&undone, 2, 5126);
    for p in e.primitives() {
        p["attributes"]["TEXCOORD_0"] = serde_json::json!(zero);
        p["attributes"]["TEXCOORD_1"] = serde_json::json!(one);
    }
    let mut textured = 0;
    for m in e.json["materials"].as_array_mut().unwrap() {
        if let Some(info) = m["pbrMetallicRoughness"].get_mut("baseColorTexture") {
            info["extensions"] = serde_json::json!({"KHR_texture_transform":
                {"offset": off, "rotation": rot, "scale": scale, "texCoord": 1}});
            textured += 1;
        }
    }
    assert!(textured > 0, "the default character has a base colour texture");
    e.json["extensionsRequired"] = serde_json::json!(["KHR_texture_transform"]);
    e.json["extensionsUsed"] = serde_json::json!(["KHR_texture_transform"]);
    let placed = e.import("texture_transform");
    let off_uv = placed
        .vertices
        .iter()
        .zip(&plain.vertices)
        .map(|(a, b)| (a.uv[0] - b.uv[0]).abs().max((a.uv[1] - b.uv[1]).abs()))
        .fold(0.0f32, f32::max);
    assert!(off_uv < 1e-5, "texture coordinates off by {off_uv}");
    assert!(
        placed.warnings.iter().all(|w| !w.contains("texture")),
        "{:?}",
        placed.warnings
    );

    // The specification's example: the unit square lands on the lower left quadrant.
    let mut e = Editable::of(&c);
    let corners: Vec<[f32; 4]> = (0..c.vertices.len())
        .map(|i| [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]][i % 4])
        .map(|[u, v]| [u, v, 0.0, 0.0])
        .collect();
    let uv = e.add(&corners, 2, 5126);
    for p in e.primitives() {
        p["attributes"]["TEXCOORD_0"] = serde_json::json!(uv);
    }
    for m in e.json["materials"].as_array_mut().unwrap() {
        if let Some(info) = m["pbrMetallicRoughness"].get_mut("baseColorTexture") {
            info["extensions"] = serde_json::json!({"KHR_texture_transform":
                {"offset": [0.0, 1.0], "rotation": std::f32::consts::FRAC_PI_2, "scale": [0.5, 0.5]}});
        }
    }
    let example = e.import("texture_transform_example");
    let want = [[0.0, 1.0], [0.0, 0.5], [0.5, 0.5], [0.5, 1.0]];
    for (i, v) in example.vertices.iter().enumerate().take(8) {
        let w = want[i % 4];
        assert!(
            (v.uv[0] - w[0]).abs() < 1e-5 && (v.uv[1] - w[1]).abs() < 1e-5,
            "corner {i}: {:?} against {w:?}",
            v.uv
        );
    }
}

/// Primitives that share one vertex buffer, each drawing a range of it (as exporters write a
/// mesh split by material or body part), bring only the vertices they draw: every vertex
/// had come in once per primitive, unused copies included, and they weighed in measures
/// taken over the vertices (a quadruped's stride speed moved). Independent answer: the same
/// triangles from one primitive.
/// The default character's one primitive as two drawing halves of its triangles from one
/// shared vertex buffer; with `own_skin`, the second half is a mesh of its own on a node of
/// its own with a copy of the skin.
fn split_in_two(c: &polypostor::Character, own_skin: bool) -> Editable {
    let mut e = Editable::of(c);
    let indices: Vec<[f32; 4]> = c.indices.iter().map(|&i| [i as f32, 0.0, 0.0, 0.0]).collect();
    let half = (indices.len() / 6) * 3;
    let a = e.add(&indices[..half], 1, 5125);
    let b = e.add(&indices[half..], 1, 5125);
    let meshes = e.json["meshes"].as_array_mut().unwrap();
    assert_eq!(meshes.len(), 1);
    assert_eq!(meshes[0]["primitives"].as_array().unwrap().len(), 1);
    let first = meshes[0]["primitives"][0].clone();
    let (mut p, mut q) = (first.clone(), first);
    p["indices"] = serde_json::json!(a);
    q["indices"] = serde_json::json!(b);
    if !own_skin {
        meshes[0]["primitives"] = serde_json::json!([p, q]);
        return e;
    }
    meshes[0]["primitives"] = serde_json::json!([p]);
    meshes.push(serde_json::json!({"name": "second", "primitives": [q]}));
    let skins = e.json["skins"].as_array_mut().unwrap();
    skins.push(skins[0].clone());
    let nodes = e.json["nodes"].as_array_mut().unwrap();
    let carrier = nodes.iter().position(|n| n.get("mesh").is_some()).unwrap();
    let mut second = nodes[carrier].clone();
    second["mesh"] = serde_json::json!(1);
    second["skin"] = serde_json::json!(1);
    second["name"] = serde_json::json!("second");
    second.as_object_mut().unwrap().remove("children");
    nodes.push(second);
    let id = nodes.len() - 1;
    let scene = e.json["scene"].as_u64().unwrap_or(0) as usize;
    e.json["scenes"][scene]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!(id));
    e
}

/// The corners of every triangle, skinned at one time of the first clip.
fn triangle_corners(c: &polypostor::Character) -> Vec<Vec3> {
    let (p, _) = skin_vertices(c, &Pose::sample(c, &c.clips[0], 0.3));
    c.indices.iter().map(|&i| p[i as usize]).collect()
}

/// Primitives that share one vertex buffer, each drawing a range of it (as exporters write a
/// mesh split by material or body part), bring only the vertices they draw: every vertex
/// had come in once per primitive, unused copies included, and they weighed in measures
/// taken over the vertices (a quadruped's stride speed moved). Independent answer: the same
/// triangles from one primitive.
#[test]
fn primitives_sharing_a_vertex_buffer_bring_only_the_vertices_they_draw() {
    let c = small_character();
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    let split = split_in_two(&c, false).import("shared_vertex_buffer");
    assert_eq!(split.indices.len(), plain.indices.len());
    assert!(
        split.vertices.len() < plain.vertices.len() * 11 / 10,
        "{} vertices from {}",
        split.vertices.len(),
        plain.vertices.len()
    );
    let off = triangle_corners(&split)
        .iter()
        .zip(triangle_corners(&plain))
        .map(|(x, y)| (*x - y).length())
        .fold(0.0f32, f32::max);
    assert!(off < 1e-5, "triangle corners moved by {off}");
}

/// A mesh on a skin of its own that names the same joints with the same inverse binds (as
/// clothing or a head exported apart comes) shares the first skin's bones: each copy had
/// been a bone of its own, doubling the skinned crowd's joint data (and moving the bake a
/// little). Independent answer: the same halves on one skin.
#[test]
fn skins_naming_the_same_joints_share_their_bones() {
    let c = small_character();
    let one = split_in_two(&c, false).import("one_skin");
    let two = split_in_two(&c, true).import("two_skins");
    assert_eq!(two.bones.len(), one.bones.len(), "bones");
    assert_eq!(two.indices.len(), one.indices.len());
    let off = triangle_corners(&two)
        .iter()
        .zip(triangle_corners(&one))
        .map(|(x, y)| (*x - y).length())
        .fold(0.0f32, f32::max);
    assert!(off < 1e-5, "triangle corners moved by {off}");
    // Joints named alike but bound differently stay apart.
    let mut e = split_in_two(&c, true);
    let ibm = e.json["skins"][1]["inverseBindMatrices"].as_u64().unwrap() as usize;
    let n = e.json["accessors"][ibm]["count"].as_u64().unwrap() as usize;
    let shifted: Vec<[f32; 4]> = (0..n * 4)
        .map(|k| match k % 4 {
            3 => [0.1, 0.0, 0.0, 1.0],
            col => {
                let mut r = [0.0; 4];
                r[col] = 1.0;
                r
            }
        })
        .collect();
    let id = e.add(&shifted, 4, 5126);
    e.json["accessors"][id]["count"] = serde_json::json!(n);
    e.json["accessors"][id]["type"] = serde_json::json!("MAT4");
    e.json["skins"][1]["inverseBindMatrices"] = serde_json::json!(id);
    let apart = e.import("two_skins_apart");
    assert_eq!(apart.bones.len(), one.bones.len() * 2);
}

/// glTF's alpha modes: `MASK` keeps its `alphaCutoff` (0.5 when not given), `BLEND` is drawn
/// as a cut-out at 0.5 (said), `OPAQUE` ignores alpha; they had all been drawn opaque.
#[test]
fn alpha_modes_become_cut_offs() {
    let c = small_character();
    for (mode, cutoff, want, said) in [
        ("MASK", Some(0.3), 0.3f32, false),
        ("MASK", None, 0.5, false),
        ("BLEND", None, 0.5, true),
        ("OPAQUE", Some(0.7), 0.0, false),
    ] {
        let mut e = Editable::of(&c);
        for m in e.json["materials"].as_array_mut().unwrap() {
            m["alphaMode"] = serde_json::json!(mode);
            if let Some(x) = cutoff {
                m["alphaCutoff"] = serde_json::json!(x);
            }
        }
        let back = e.import(&format!("alpha_{mode}"));
        for m in &back.materials {
            assert!((m.alpha_cutoff - want).abs() < 1e-6, "{mode}: {}", m.alpha_cutoff);
        }
        assert_eq!(
            back.warnings.iter().any(|w| w.contains("cut-out")),
            said,
            "{mode}: {:?}",
            back.warnings
        );
    }
    // Our own writer keeps a cut-off.
    let mut masked = c.clone();
    masked.materials[0].alpha_cutoff = 0.25;
    let back = import_slice(&write_glb(&masked).unwrap(), None, "x").unwrap();
    assert!((back.materials[0].alpha_cutoff - 0.25).abs() < 1e-6);
}

/// Bad input on the paths above gets an error naming the problem (or, where the file can
/// still be drawn, is read safely): a morph target with the wrong count or non-finite
/// deltas, a non-finite default weight, JOINTS_1 without WEIGHTS_1, a texture transform
/// with non-finite numbers.
#[test]
fn bad_morph_influence_and_transform_data_are_named() {
    let c = small_character();
    let n = c.vertices.len();
    // A target one vertex short.
    let mut e = Editable::of(&c);
    let short = e.add(&vec![[0.0, 0.1, 0.0, 0.0]; n - 1], 3, 5126);
    for p in e.primitives() {
        p["targets"] = serde_json::json!([{"POSITION": short}]);
    }
    e.json["meshes"][0]["weights"] = serde_json::json!([1.0]);
    let err = e.import_error("bad_morph_count");
    assert!(err.contains("morph target 0 POSITION"), "{err}");
    // A target one vertex long at default weight 0 that a clip animates: read when the
    // clip's offsets are kept, and refused there too.
    let mut e = Editable::of(&c);
    let long = e.add(&vec![[0.0, 0.1, 0.0, 0.0]; n + 1], 3, 5126);
    for p in e.primitives() {
        p["targets"] = serde_json::json!([{"POSITION": long}]);
    }
    animate_weights(&mut e, &[[0.0; 4], [1.0, 0.0, 0.0, 0.0]], "LINEAR");
    let err = e.import_error("bad_animated_morph_count");
    assert!(
        err.contains("morph target 0 POSITION") && err.contains("one per vertex"),
        "{err}"
    );
    // Non-finite deltas.
    let mut e = Editable::of(&c);
    let nan = e.add(&vec![[f32::NAN, 0.0, 0.0, 0.0]; n], 3, 5126);
    for p in e.primitives() {
        p["targets"] = serde_json::json!([{"POSITION": nan}]);
    }
    e.json["meshes"][0]["weights"] = serde_json::json!([0.5]);
    let err = e.import_error("bad_morph_nan");
    assert!(err.contains("finite"), "{err}");
    // A target at weight 0 is not read at all: nothing to refuse.
    let mut e = Editable::of(&c);
    let nan = e.add(&vec![[f32::NAN, 0.0, 0.0, 0.0]; n], 3, 5126);
    for p in e.primitives() {
        p["targets"] = serde_json::json!([{"POSITION": nan}]);
    }
    assert_eq!(e.import_error("morph_at_zero"), "");
    // JOINTS_1 alone.
    let mut e = Editable::of(&c);
    let joints = e.add(&vec![[0.0; 4]; n], 4, 5123);
    for p in e.primitives() {
        p["attributes"]["JOINTS_1"] = serde_json::json!(joints);
    }
    let err = e.import_error("joints_alone");
    assert!(err.contains("JOINTS_1 and WEIGHTS_1"), "{err}");
    // A texture transform whose numbers are not finite reads as no transform (JSON has no
    // NaN: an absurd number stands in for one that overflows).
    let mut e = Editable::of(&c);
    for m in e.json["materials"].as_array_mut().unwrap() {
        if let Some(info) = m["pbrMetallicRoughness"].get_mut("baseColorTexture") {
            info["extensions"] = serde_json::json!({"KHR_texture_transform":
                {"offset": [1e39, 0.0], "rotation": 1e39, "scale": [1e39, 1.0]}});
        }
    }
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    let placed = e.import("transform_overflow");
    assert!(placed.vertices.iter().zip(&plain.vertices).all(|(a, b)| a.uv == b.uv));
}

/// A file exported lying down (a Z-up tool's export left unconverted, or any axis) is read
/// standing when the artist names its up axis. Independent answer: the character laid down
/// by an explicit quarter (or half) turn at a new root node, as such files come, then read
/// with that axis up, skins to the original's positions at every sampled time.
#[test]
fn a_file_lying_along_any_axis_stands_up_when_its_up_axis_is_given() {
    use polypostor::{ImportOptions, UpAxis};
    let c = small_character();
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    let original = poses_of(&plain);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    // The turn that takes +y to the named axis, written out (x, y, z, w).
    for (up, lay) in [
        (UpAxis::PosZ, [h, 0.0, 0.0, h]),
        (UpAxis::NegZ, [-h, 0.0, 0.0, h]),
        (UpAxis::PosX, [0.0, 0.0, -h, h]),
        (UpAxis::NegX, [0.0, 0.0, h, h]),
        (UpAxis::NegY, [1.0, 0.0, 0.0, 0.0]),
    ] {
        let laid_up = Quat::from_array(lay) * Vec3::Y;
        assert!((laid_up - up.direction()).length() < 1e-6, "{up}: the test's turn");
        let lying = |e: &mut Editable| {
            let scene = e.json["scene"].as_u64().unwrap_or(0) as usize;
            let roots = e.json["scenes"][scene]["nodes"].clone();
            let nodes = e.json["nodes"].as_array_mut().unwrap();
            nodes.push(serde_json::json!({"name": "lying", "rotation": lay, "children": roots}));
            let root = nodes.len() - 1;
            e.json["scenes"][scene]["nodes"] = serde_json::json!([root]);
        };
        let mut as_file = Editable::of(&c);
        lying(&mut as_file);
        let read_plain = as_file
            .try_import_with("lying_plain", ImportOptions::default())
            .unwrap();
        let off = largest_offset(&poses_of(&read_plain), &original);
        assert!(off > 0.5, "{up}: read as glTF says, it lies ({off})");
        assert_eq!(read_plain.up_axis, UpAxis::PosY);
        let mut as_file = Editable::of(&c);
        lying(&mut as_file);
        let stood = as_file.try_import_with("lying_stood", ImportOptions { up }).unwrap();
        let off = largest_offset(&poses_of(&stood), &original);
        assert!(off < 1e-4, "{up}: stood up, largest offset {off}");
        assert_eq!(stood.up_axis, up);
        assert!(
            stood.warnings.iter().any(|w| w.contains(&format!("{up} as up"))),
            "{:?}",
            stood.warnings
        );
        // Lying along z (a Z-up export), the import says what to do.
        let hinted = read_plain.warnings.iter().any(|w| w.contains("--up z"));
        assert_eq!(
            hinted,
            matches!(up, UpAxis::PosZ | UpAxis::NegZ),
            "{up}: {:?}",
            read_plain.warnings
        );
    }
    // Standing, it is not hinted at; names parse both ways.
    assert!(plain.warnings.iter().all(|w| !w.contains("--up")));
    for a in UpAxis::ALL {
        assert_eq!(UpAxis::parse(a.name()), Some(a));
        assert!((a.rotation() * a.direction() - Vec3::Y).length() < 1e-6, "{a}");
    }
    assert_eq!(UpAxis::parse("Z"), Some(UpAxis::PosZ));
    assert_eq!(UpAxis::parse("up"), None);
}

/// Required extensions: lights and metadata leave the character as it is (imported, with a
/// warning naming them); compression and image formats the importer cannot read are refused
/// by name before any work (a file of Bevy's examples requires KHR_lights_punctual for one
/// point light).
#[test]
fn required_extensions_are_ignored_only_where_they_change_nothing() {
    let c = small_character();
    let plain = import_slice(&write_glb(&c).unwrap(), None, "x").unwrap();
    for ext in ["KHR_lights_punctual", "EXT_lights_image_based", "KHR_xmp_json_ld"] {
        let mut e = Editable::of(&c);
        e.json["extensionsRequired"] = serde_json::json!([ext]);
        e.json["extensionsUsed"] = serde_json::json!([ext]);
        if ext == "KHR_lights_punctual" {
            e.json["extensions"] = serde_json::json!({ext: {"lights": [{"type": "point", "intensity": 80.0}]}});
            e.json["nodes"][0]["extensions"] = serde_json::json!({ext: {"light": 0}});
        }
        let lit = e.import("required_light");
        assert_eq!(lit.vertices.len(), plain.vertices.len(), "{ext}");
        assert!(
            lit.vertices
                .iter()
                .zip(&plain.vertices)
                .all(|(a, b)| a.position == b.position),
            "{ext} moved the mesh"
        );
        assert_eq!(lit.clips.len(), plain.clips.len(), "{ext}");
        assert!(
            lit.warnings.iter().any(|w| w.contains(ext)),
            "{ext}: {:?}",
            lit.warnings
        );
    }
    for ext in [
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "KHR_texture_basisu",
        "EXT_texture_webp",
    ] {
        let mut e = Editable::of(&c);
        e.json["extensionsRequired"] = serde_json::json!([ext]);
        e.json["extensionsUsed"] = serde_json::json!([ext]);
        let err = e.import_error("required_unreadable");
        assert!(err.contains(ext), "{ext}: {err:?}");
    }
}

/// A repository cloned without Git LFS holds a few lines of text in place of each model,
/// buffer and texture (met in a game's repository of Bevy assets): the import says so, and how
/// to get the real file, instead of "invalid JSON" or a short buffer.
#[test]
fn git_lfs_pointers_are_named_for_what_they_are() {
    let pointer = b"version https://git-lfs.github.com/spec/v1\noid sha256:c696d4ead56e104d1393b7f6860a6cee68cdd744a8d5db46d63c1b0715068bd1\nsize 120240\n";
    let dir = common::temp_dir("lfs_pointer");
    let glb = dir.join("area.glb");
    std::fs::write(&glb, pointer).unwrap();
    let err = polypostor::import_path_with(&glb, Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("Git LFS pointer") && err.contains("120240") && err.contains("git lfs pull"),
        "{err}"
    );
    std::fs::remove_dir_all(dir).unwrap();

    // The model itself is there, its external buffer is a pointer.
    let mut e = Editable::of(&small_character());
    e.bin = pointer.to_vec();
    let err = e.import_error("lfs_buffer");
    assert!(err.contains("Git LFS pointer") && err.contains("b.bin"), "{err}");
    // Anything else of that length still reads as what it is.
    assert!(polypostor::import::lfs_pointer(b"version 2\nsize 12\n").is_none());
    assert!(polypostor::import::lfs_pointer(&[b' '; 2000]).is_none());
}

/// Emission is not drawn (every representation is lit base colour): a material with an
/// emissive colour or texture is named in a warning; the same file without one says nothing.
#[test]
fn an_emissive_material_is_said_not_to_glow() {
    let c = small_character();
    let plain = Editable::of(&c).import("emissive_plain");
    assert!(
        plain.warnings.iter().all(|w| !w.contains("emissive")),
        "{:?}",
        plain.warnings
    );
    let mut e = Editable::of(&c);
    e.json["materials"][0]["emissiveFactor"] = serde_json::json!([0.0, 1.0, 0.0]);
    e.json["materials"][0]["name"] = serde_json::json!("Visor");
    let glowing = e.import("emissive");
    assert!(
        glowing
            .warnings
            .iter()
            .any(|w| w.contains("material 0 'Visor'") && w.contains("emissive")),
        "{:?}",
        glowing.warnings
    );
}

/// A texture's sampler wrap modes reach the material (repeat where the file names none), and
/// our own writer keeps them: write, import, the same modes.
#[test]
fn texture_wrap_modes_are_read_and_written() {
    use polypostor::character::TextureWrap;
    let c = small_character();
    let plain = Editable::of(&c).import("wrap_plain");
    let textured = plain.materials.iter().position(|m| m.base_color_texture.is_some());
    let Some(k) = textured else {
        panic!("the small character has a textured material");
    };
    assert_eq!(plain.materials[k].wrap, [TextureWrap::Repeat; 2]);
    let mut e = Editable::of(&c);
    e.json["samplers"] = serde_json::json!([{"wrapS": 33648, "wrapT": 33071}]);
    for t in e.json["textures"].as_array_mut().unwrap() {
        t["sampler"] = serde_json::json!(0);
    }
    let wrapped = e.import("wrap");
    assert_eq!(
        wrapped.materials[k].wrap,
        [TextureWrap::MirroredRepeat, TextureWrap::ClampToEdge]
    );
    let back = import_slice(&write_glb(&wrapped).unwrap(), None, "x").unwrap();
    let modes: Vec<_> = back.materials.iter().map(|m| (m.name.clone(), m.wrap)).collect();
    let want: Vec<_> = wrapped.materials.iter().map(|m| (m.name.clone(), m.wrap)).collect();
    assert_eq!(modes, want);
}

/// A character read with an up axis of the wrong sign stands on its head: said, with the
/// axis that stands it up (the default read right side up says nothing).
#[test]
fn a_character_read_upside_down_is_said_to_stand_on_its_head() {
    use polypostor::{ImportOptions, UpAxis};
    let bytes = write_glb(&small_character()).unwrap();
    let upright = import_slice(&bytes, None, "x").unwrap();
    assert!(
        upright.warnings.iter().all(|w| !w.contains("on its head")),
        "{:?}",
        upright.warnings
    );
    let options = ImportOptions {
        up: UpAxis::NegY,
        ..Default::default()
    };
    let flipped = polypostor::import::import_slice_with(&bytes, None, "x", options).unwrap();
    assert!(
        flipped
            .warnings
            .iter()
            .any(|w| w.contains("on its head") && w.contains("+y as up")),
        "{:?}",
        flipped.warnings
    );
}
