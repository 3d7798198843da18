//! Every WGSL file in `shaders/` parses and validates with naga, and the library embeds them all.

use std::path::PathBuf;

#[test]
fn every_shader_validates() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "wgsl"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    for f in &files {
        let src = std::fs::read_to_string(f).unwrap();
        let name = f.file_name().unwrap().to_string_lossy();
        let embedded = polypostor::gpu::shaders::ALL
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| panic!("{name} is not embedded in gpu::shaders::ALL"));
        // Crowd shaders are embedded with crowd_common.wgsl prepended (WGSL has no includes).
        let common = polypostor::gpu::shaders::CROWD_COMMON;
        assert!(
            embedded.1 == src || (embedded.1.starts_with(common) && embedded.1[common.len()..] == src),
            "{name}: embedded copy differs"
        );
        // Validate what the pipelines compile.
        let full = embedded.1;
        let module = naga::front::wgsl::parse_str(full)
            .unwrap_or_else(|e| panic!("{}: {}", f.display(), e.emit_to_string(full)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}: {}", f.display(), e.emit_to_string(full)));
    }
    assert_eq!(files.len(), polypostor::gpu::shaders::ALL.len());
}
