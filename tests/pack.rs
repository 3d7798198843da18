//! Pack round trip and damaged packs: write, load back identical; every kind of damage gives
//! a clear error, never a panic.

mod common;

use polypostor::bake::pipeline::{BakeOptions, KeyFrame};
use polypostor::pack::{PackError, load_pack, write_pack};

/// How far a stored position may lie from the fitted one, in view-plane units ([-1, 1]): half
/// a step of the block's box (its extent over the block's frames in 255 steps) and the box's
/// snap to u16 steps. Independent of the writer: computed from the fit, in pixels of a view
/// `r` wide.
fn position_bound(frames: impl Iterator<Item = Vec<[f32; 2]>>, r: f32) -> [f32; 2] {
    let mut lo = [f32::INFINITY; 2];
    let mut hi = [f32::NEG_INFINITY; 2];
    for q in frames.flatten() {
        for a in 0..2 {
            lo[a] = lo[a].min(q[a]);
            hi[a] = hi[a].max(q[a]);
        }
    }
    let bound = [0, 1].map(|a| (hi[a] - lo[a]) / r / 255.0 + 4.0 / 65535.0);
    // Never coarser than a step of a box the whole view wide.
    assert!(bound.iter().all(|&b| b <= 2.0 / 255.0 + 4.0 / 65535.0), "{bound:?}");
    bound
}

#[test]
fn pack_round_trip_and_damage() {
    let ctx = common::gpu();
    // PNG atlases: this checks the round trip texel for texel (BC7 is lossy; its own round
    // trip is in tests/bc_textures.rs).
    let options = BakeOptions {
        views: 3,
        resolution: 64,
        key_frame: KeyFrame::Frame(2),
        textures: polypostor::bake::pipeline::TextureEncoding::Png,
        ..Default::default()
    };
    let (c, b) = common::bake_default(&ctx, &options);
    let dir = common::temp_dir("pack");
    let out = dir.join("walk.pack");
    let stats = write_pack(&b, &c.name, Some("Walk"), &out).unwrap();
    assert!(stats.pack_bytes > 0 && stats.triangles_per_view > 0.0);
    let p = load_pack(&out).unwrap();
    assert_eq!(p.manifest.views.len(), 3);
    assert_eq!(p.manifest.frames, 10);
    assert_eq!(p.manifest.key_frame, 2);
    // Vertex data matches the bake: positions of part 0 in view 0 at frame 5.
    let fit = b.views[0].parts[0].fit.as_ref().unwrap();
    let (_, pos) = p.part_vertices(0, 0, 5).unwrap();
    let want = fit.positions(5);
    let bound = position_bound((0..10).map(|f| fit.positions(f)), 64.0);
    for (k, q) in want.iter().enumerate() {
        // Stored as a byte of the block's box: within half a step of it.
        assert!((pos[2 * k] - (q[0] / 64.0 * 2.0 - 1.0)).abs() <= bound[0]);
        assert!((pos[2 * k + 1] - (1.0 - q[1] / 64.0 * 2.0)).abs() <= bound[1]);
    }
    // Texture coordinates find the key-frame texels they were cut from (crops may be stored
    // transposed): the centre of every triangle, mapped through the pack's UVs, reads the same
    // colour as in the key-frame render.
    let mut checked = 0;
    for (v, view) in b.views.iter().enumerate() {
        let [aw, ah] = p.manifest.views[v].atlas_size;
        for (pi, part) in view.parts.iter().enumerate() {
            let Some(fit) = &part.fit else { continue };
            let (uv, _) = p.part_vertices(v, pi, 0).unwrap();
            let tile_uv = fit.uvs();
            for t in &fit.triangles {
                let c_tile = t.iter().fold([0.0f32; 2], |a, &i| {
                    [a[0] + tile_uv[i][0] / 3.0, a[1] + tile_uv[i][1] / 3.0]
                });
                let c_atlas = t.iter().fold([0.0f32; 2], |a, &i| {
                    [
                        a[0] + uv[2 * i] * aw as f32 / 3.0,
                        a[1] + uv[2 * i + 1] * ah as f32 / 3.0,
                    ]
                });
                // Skip centres within quantisation noise of a texel edge.
                if c_tile.iter().chain(&c_atlas).any(|x| (x - x.round()).abs() < 0.01) {
                    continue;
                }
                let want = part.key_color.get_pixel(c_tile[0] as u32, c_tile[1] as u32);
                if want[3] == 0 {
                    continue; // outside the mask: dilation may have filled it
                }
                let got = p.views[v].atlas.get_pixel(c_atlas[0] as u32, c_atlas[1] as u32);
                assert_eq!(got, want, "view {v} part {pi} triangle {t:?}");
                checked += 1;
            }
        }
    }
    assert!(checked > 50, "{checked}");
    // The normal atlas is the colour atlas's layout at half resolution.
    let [aw, ah] = p.manifest.views[0].atlas_size;
    assert_eq!(p.views[0].atlas.dimensions(), (aw, ah));
    assert_eq!(p.views[0].normals.dimensions(), (aw / 2, ah / 2));
    // Writing again replaces the pack in one step and leaves no temporary folders.
    write_pack(&b, &c.name, Some("Walk"), &out).unwrap();
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name() != "walk.pack")
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // Every drawn part has its coarse level: half its outline's vertices (the bake's
    // simplification continued; interior vertices are not drawn there), fewer triangles,
    // indices inside its block.
    let mut coarse = 0;
    for (view, baked) in p.manifest.views.iter().zip(&b.views) {
        for (part, fit) in view.parts.iter().zip(&baked.parts) {
            let (Some(part), Some(fit)) = (part, &fit.fit) else {
                continue;
            };
            assert_eq!(part.vertex_count as usize, fit.kept.len() + fit.interior.len());
            assert!(part.coarse_index_count > 0 && part.coarse_index_count < part.index_count);
            let start = part.coarse_index_offset as usize;
            let list = &p.indices[start..start + part.coarse_index_count as usize];
            let mut used: Vec<u16> = list.to_vec();
            used.sort_unstable();
            used.dedup();
            assert_eq!(used.len(), fit.kept.len() / 2);
            assert!(used.iter().all(|&i| usize::from(i) < fit.kept.len()));
            coarse += 1;
        }
    }
    assert!(coarse > 0);

    // Damage, one kind at a time, on copies.
    let manifest_text = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    let copy = |name: &str| {
        let d = dir.join(name);
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        for e in std::fs::read_dir(&out).unwrap().filter_map(|e| e.ok()) {
            std::fs::copy(e.path(), d.join(e.file_name())).unwrap();
        }
        d
    };
    let edit = |name: &str, f: &dyn Fn(&mut serde_json::Value)| {
        let d = copy(name);
        let mut v: serde_json::Value = serde_json::from_str(&manifest_text).unwrap();
        f(&mut v);
        std::fs::write(d.join("manifest.json"), serde_json::to_string(&v).unwrap()).unwrap();
        load_pack(&d)
            .err()
            .unwrap_or_else(|| panic!("{name}: damaged pack loaded"))
    };
    let e = edit("version", &|v| v["version"] = 99.into());
    assert!(matches!(e, PackError::Version { found: 99, .. }), "{e}");
    let e = edit("offset", &|v| {
        v["views"][0]["parts"][0]["vertex_offset"] = 1_000_000_000u64.into()
    });
    assert!(e.to_string().contains("past the end"), "{e}");
    let e = edit("coarse", &|v| {
        v["views"][0]["parts"][0]["coarse_index_offset"] = 4_000_000_000u64.into()
    });
    assert!(e.to_string().contains("coarse indices"), "{e}");
    let e = edit("huge", &|v| v["views"][0]["parts"][0]["vertex_count"] = u32::MAX.into());
    assert!(matches!(e, PackError::Damaged(_)), "{e}");
    let e = edit("order", &|v| {
        v["views"][1]["order"] = serde_json::json!([0, 0, 1, 2, 3])
    });
    assert!(e.to_string().contains("permutation"), "{e}");
    let e = edit("rect", &|v| {
        v["views"][0]["parts"][1]["atlas_rect"] = serde_json::json!([0, 0, 100000, 4])
    });
    assert!(e.to_string().contains("atlas"), "{e}");
    let e = edit("escape", &|v| v["views"][0]["atlas"] = "../../etc/passwd".into());
    assert!(e.to_string().contains("plain name"), "{e}");
    let e = edit("frames", &|v| v["frames"] = 0.into());
    assert!(matches!(e, PackError::Damaged(_)), "{e}");
    // Two parts' blocks on the same values: refused before decoding more than the file holds.
    let e = edit("overlap", &|v| {
        let first = v["views"][0]["parts"][0]["vertex_offset"].clone();
        for view in v["views"].as_array_mut().unwrap() {
            for part in view["parts"].as_array_mut().unwrap() {
                if part.is_object() {
                    part["vertex_offset"] = first.clone();
                }
            }
        }
    });
    assert!(e.to_string().contains("overlap"), "{e}");
    // Vertex data rewritten with its checksum (so only the content check can catch it).
    let rewrite = |name: &str, f: &dyn Fn(&mut Vec<u8>, &serde_json::Value), edit: &dyn Fn(&mut serde_json::Value)| {
        let d = copy(name);
        let mut v: serde_json::Value = serde_json::from_str(&manifest_text).unwrap();
        let mut bytes = std::fs::read(d.join("vertices.bin")).unwrap();
        f(&mut bytes, &v);
        edit(&mut v);
        let sum = polypostor::pack::FileSum::of(&bytes);
        v["checksums"]["vertices.bin"] = serde_json::to_value(sum).unwrap();
        v["vertex_bytes"] = bytes.len().into();
        std::fs::write(d.join("vertices.bin"), &bytes).unwrap();
        std::fs::write(d.join("manifest.json"), serde_json::to_string(&v).unwrap()).unwrap();
        d
    };
    // A position box of size 0 (after the first part's UVs).
    let d = rewrite(
        "box",
        &|bytes, v| {
            let part = &v["views"][0]["parts"][0];
            let at = (part["vertex_offset"].as_u64().unwrap() + 2 * part["vertex_count"].as_u64().unwrap()) as usize;
            bytes[2 * at + 4..2 * at + 8].fill(0);
        },
        &|_| {},
    );
    let e = load_pack(&d).unwrap_err();
    assert!(e.to_string().contains("position box"), "{e}");
    // A format-6 pack (positions as u16 pairs, no boxes) still loads, to the same values
    // within a u16 step: written here from the format-7 pack's decoded layout.
    let words: Vec<u8> = p
        .vertices
        .iter()
        .flat_map(|&x| ((x.clamp(0.0, 1.0) * 65535.0).round() as u16).to_le_bytes())
        .collect();
    let offsets: Vec<Vec<Option<u64>>> = p
        .manifest
        .views
        .iter()
        .map(|v| v.parts.iter().map(|q| q.as_ref().map(|q| q.vertex_offset)).collect())
        .collect();
    let d = rewrite("format6", &|bytes, _| *bytes = words.clone(), &|v| {
        v["version"] = 6.into();
        for (view, offs) in v["views"].as_array_mut().unwrap().iter_mut().zip(&offsets) {
            for (part, o) in view["parts"].as_array_mut().unwrap().iter_mut().zip(offs) {
                if let Some(o) = o {
                    part["vertex_offset"] = (*o).into();
                }
            }
        }
    });
    let old = load_pack(&d).unwrap();
    assert_eq!(old.manifest.version, 6);
    for (v, view) in p.manifest.views.iter().enumerate() {
        for (pi, part) in view.parts.iter().enumerate() {
            if part.is_none() {
                continue;
            }
            for f in [0, 5, 9] {
                let (uv7, pos7) = p.part_vertices(v, pi, f).unwrap();
                let (uv6, pos6) = old.part_vertices(v, pi, f).unwrap();
                for (a, b) in uv7.iter().chain(&pos7).zip(uv6.iter().chain(&pos6)) {
                    assert!(
                        (a - b).abs() <= 2.0 / 65535.0,
                        "view {v} part {pi} frame {f}: {a} vs {b}"
                    );
                }
            }
        }
    }
    // Truncated vertex data, garbage manifest, broken atlas image.
    let d = copy("truncated");
    let bytes = std::fs::read(d.join("vertices.bin")).unwrap();
    std::fs::write(d.join("vertices.bin"), &bytes[..bytes.len() / 2]).unwrap();
    assert!(matches!(load_pack(&d), Err(PackError::Damaged(_))));
    let d = copy("garbage");
    std::fs::write(d.join("manifest.json"), "{ nope").unwrap();
    assert!(matches!(load_pack(&d), Err(PackError::Manifest { .. })));
    let d = copy("image");
    std::fs::write(d.join("atlas_001.png"), b"\x89PNG broken").unwrap();
    assert!(load_pack(&d).unwrap_err().to_string().contains("atlas_001.png"));
    // A file replaced without updating the manifest: its checksum says so.
    let d = copy("normals");
    let small = image::RgbaImage::new(2, 2);
    small.save(d.join("normal_002.png")).unwrap();
    let e = load_pack(&d).unwrap_err().to_string();
    assert!(e.contains("normal_002.png"), "{e}");
    // Forged with matching checksums, the content checks still hold: the size of the image,
    common::reseal(&d.join("manifest.json"));
    let e = load_pack(&d).unwrap_err().to_string();
    assert!(e.contains("normal_002.png") && e.contains("2×2"), "{e}");
    // a bad index inside the index data.
    let d = copy("index");
    let mut bytes = std::fs::read(d.join("indices.bin")).unwrap();
    bytes[0] = 0xff;
    bytes[1] = 0x7f;
    std::fs::write(d.join("indices.bin"), &bytes).unwrap();
    assert!(load_pack(&d).unwrap_err().to_string().contains("checksum"));
    common::reseal(&d.join("manifest.json"));
    assert!(load_pack(&d).unwrap_err().to_string().contains("refers past"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn several_key_images_round_trip_and_damaged_key_tables_are_refused() {
    let ctx = common::gpu();
    let (c, b) = common::bake_default(&ctx, &common::cheap_keys(3, 64));
    let dir = common::temp_dir("pack-keys");
    let out = dir.join("walk.pack");
    let stats = write_pack(&b, &c.name, Some("Walk"), &out).unwrap();
    let p = load_pack(&out).unwrap();
    let frames = p.manifest.frames as usize;
    let mut extra = 0;
    let mut checked = 0;
    for (v, view) in b.views.iter().enumerate() {
        for (pi, part) in view.parts.iter().enumerate() {
            let Some(m) = p.manifest.views[v].parts[pi].as_ref() else {
                assert!(part.fit.is_none());
                continue;
            };
            assert_eq!(m.extra_keys.len(), part.extra.len(), "view {v} part {pi}");
            assert_eq!(m.frame_keys, part.frame_key, "view {v} part {pi}");
            extra += part.extra.len();
            for (k, e) in part.extra.iter().enumerate() {
                assert_eq!(m.extra_keys[k].key_frame as usize, e.frame);
                // Every frame of the key's span is stored, as fitted.
                for f in 0..frames {
                    let got = p.key_vertices(v, pi, k + 1, f);
                    assert_eq!(
                        got.is_some(),
                        e.span.contains(f, frames),
                        "view {v} part {pi} key {k} frame {f}"
                    );
                    let Some((_, pos)) = got else { continue };
                    let span = (0..frames).filter(|&g| e.span.contains(g, frames));
                    let bound = position_bound(span.map(|g| e.fit.positions(g)), 64.0);
                    for (i, q) in e.fit.positions(f).iter().enumerate() {
                        assert!((pos[2 * i] - (q[0] / 64.0 * 2.0 - 1.0)).abs() <= bound[0]);
                        assert!((pos[2 * i + 1] - (1.0 - q[1] / 64.0 * 2.0)).abs() <= bound[1]);
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(extra > 0, "no part got a second key");
    assert!(checked > 0);
    assert!(stats.extra_key_bytes > 0);
    // A part with several keys to damage.
    let (v, pi) = p
        .manifest
        .views
        .iter()
        .enumerate()
        .find_map(|(v, view)| {
            view.parts
                .iter()
                .position(|q| q.as_ref().is_some_and(|q| !q.extra_keys.is_empty()))
                .map(|pi| (v, pi))
        })
        .unwrap();
    let manifest_text = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    let damage = |name: &str, f: &dyn Fn(&mut serde_json::Value)| -> String {
        let d = dir.join(name);
        common::copy_folder(&out, &d);
        let mut m: serde_json::Value = serde_json::from_str(&manifest_text).unwrap();
        f(&mut m["views"][v]["parts"][pi]);
        std::fs::write(d.join("manifest.json"), serde_json::to_string(&m).unwrap()).unwrap();
        load_pack(&d)
            .err()
            .unwrap_or_else(|| panic!("{name}: damaged pack loaded"))
            .to_string()
    };
    let e = damage("key-missing", &|q| q["frame_keys"][0] = 9.into());
    assert!(e.contains("does not have"), "{e}");
    let e = damage("key-table-short", &|q| {
        q["frame_keys"].as_array_mut().unwrap().pop();
    });
    assert!(e.contains("frame keys"), "{e}");
    let e = damage("key-table-gone", &|q| q["frame_keys"] = serde_json::json!([]));
    assert!(e.contains("extra keys"), "{e}");
    let e = damage("key-span-empty", &|q| q["extra_keys"][0]["frame_count"] = 0.into());
    assert!(e.contains("do not fit"), "{e}");
    let e = damage("key-offset", &|q| {
        q["extra_keys"][0]["vertex_offset"] = 4_000_000_000u64.into()
    });
    assert!(e.contains("past the end"), "{e}");
    // The key table names the key for a frame its polygon was not fitted to.
    let e = damage("key-uncovered", &|q| {
        let key = q["extra_keys"][0].clone();
        let (start, count) = (
            key["frame_start"].as_u64().unwrap() as usize,
            key["frame_count"].as_u64().unwrap() as usize,
        );
        if count < frames {
            let outside = (start + count) % frames;
            q["frame_keys"][outside] = 1.into();
        } else {
            q["extra_keys"][0]["frame_count"] = 1.into();
            q["frame_keys"][start] = 1.into();
        }
    });
    assert!(e.contains("does not cover"), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}
