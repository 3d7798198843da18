//! The whole Khronos invalid-glTF corpus imports or fails with a clear error, never a panic;
//! the real characters import with the joints, clips and durations their files declare.

mod common;

use std::path::{Path, PathBuf};

use polypostor::ImportError;

fn corpus_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().filter_map(|e| e.ok()) {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "gltf" || x == "glb") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn invalid_corpus_never_panics_and_errors_name_the_problem() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let files = corpus_files(&shared.join("assets/invalid-gltf"));
    assert!(files.len() > 200, "expected the whole corpus, found {}", files.len());
    let mut panics = Vec::new();
    let (mut ok, mut err) = (0, 0);
    for f in &files {
        let result = std::panic::catch_unwind(|| polypostor::import_path(f));
        match result {
            Err(_) => panics.push(f.clone()),
            Ok(Ok(c)) => {
                ok += 1;
                eprintln!(
                    "imported {}: {} triangles, warnings {:?}",
                    f.display(),
                    c.triangle_count(),
                    c.warnings
                );
                assert!(c.triangle_count() > 0);
                assert!(c.vertices.iter().all(|v| v.position.is_finite()));
                let n = c.vertices.len() as u32;
                assert!(c.indices.iter().all(|&i| i < n), "{}", f.display());
            }
            Ok(Err(e)) => {
                err += 1;
                let msg = e.to_string();
                eprintln!("rejected {}: {msg}", f.display());
                assert!(msg.len() > 12, "{}: uninformative error '{msg}'", f.display());
            }
        }
    }
    eprintln!(
        "corpus: {} files, {ok} imported, {err} rejected with an error",
        files.len()
    );
    assert!(panics.is_empty(), "import panicked on: {panics:#?}");
    assert!(ok > 0 && err > 100);
}

#[test]
fn specific_corpus_cases_give_the_expected_error_kind() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let base = shared.join("assets/invalid-gltf");
    let case = |rel: &str| polypostor::import_path(&base.join(rel));
    assert!(matches!(case("glb/invalid_magic.glb"), Err(ImportError::Glb(m)) if m.contains("magic")));
    assert!(matches!(
        case("glb/empty_file.glb"),
        Err(ImportError::Json(_) | ImportError::Glb(_))
    ));
    assert!(matches!(case("glb/truncated_chunk_data.glb"), Err(ImportError::Glb(_))));
    assert!(matches!(case("glb/two_bin_chunks.glb"), Err(ImportError::Glb(_))));
    assert!(matches!(case("json/invalid_syntax.gltf"), Err(ImportError::Json(_))));
    assert!(matches!(case("json/bom.gltf"), Err(ImportError::Json(m)) if m.contains("BOM")));
    assert!(matches!(case("asset/1_0_version.gltf"), Err(ImportError::Unsupported(m)) if m.contains("1.0")));
    let loop_err = case("node/node_loop.gltf").unwrap_err().to_string();
    assert!(
        loop_err.contains("cycle") || loop_err.contains("parent") || loop_err.contains("own child"),
        "{loop_err}"
    );
}

/// What the file declares, read with serde_json alone (independent of the importer).
struct Declared {
    joints: usize,
    clips: Vec<(String, f32)>,
}

fn declared(path: &Path) -> Declared {
    let bytes = std::fs::read(path).unwrap();
    let json_bytes = if &bytes[0..4] == b"glTF" {
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        bytes[20..20 + len].to_vec()
    } else {
        bytes
    };
    let v: serde_json::Value = serde_json::from_slice(&json_bytes).unwrap();
    let mut joints: Vec<u64> = v["skins"]
        .as_array()
        .map(|s| {
            s.iter()
                .flat_map(|s| s["joints"].as_array().unwrap().iter().map(|j| j.as_u64().unwrap()))
                .collect()
        })
        .unwrap_or_default();
    joints.sort();
    joints.dedup();
    let accessors = v["accessors"].as_array().cloned().unwrap_or_default();
    let clips = v["animations"]
        .as_array()
        .map(|a| {
            a.iter()
                .enumerate()
                .map(|(i, anim)| {
                    let name = anim["name"]
                        .as_str()
                        .map(String::from)
                        .unwrap_or_else(|| format!("Animation {i}"));
                    let end = anim["samplers"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|s| {
                            accessors[s["input"].as_u64().unwrap() as usize]["max"][0]
                                .as_f64()
                                .unwrap() as f32
                        })
                        .fold(0.0f32, f32::max);
                    (name, end)
                })
                .collect()
        })
        .unwrap_or_default();
    Declared {
        joints: joints.len().max(1),
        clips,
    }
}

#[test]
fn real_characters_import_with_declared_joints_and_clips() {
    let files = common::real_characters();
    for f in &files {
        let c = polypostor::import_path(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let d = declared(f);
        let s = polypostor::summary::Summary::of(&c);
        eprintln!(
            "{}: {} vertices, {} triangles, {} joints, {} clips, warnings {:?}",
            f.display(),
            s.vertices,
            s.triangles,
            s.joints,
            s.clips.len(),
            s.warnings
        );
        assert_eq!(s.joints, d.joints, "{}", f.display());
        assert_eq!(s.clips.len(), d.clips.len(), "{}", f.display());
        for (got, want) in s.clips.iter().zip(&d.clips) {
            assert_eq!(got.name, want.0);
            assert!(
                (got.duration_secs - want.1).abs() < 1e-4,
                "{}: {} {} vs {}",
                f.display(),
                got.name,
                got.duration_secs,
                want.1
            );
        }
        assert!(s.triangles > 0 && s.vertices > 0);
        for v in &c.vertices {
            let sum: f32 = v.weights.iter().sum();
            assert!((sum - 1.0).abs() < 1e-4);
            assert!(v.bones.iter().all(|&b| (b as usize) < c.bones.len()));
        }
    }
}
