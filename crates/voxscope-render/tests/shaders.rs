//! Every shader voxscope compiles parses and validates with naga, as composed (WGSL has no
//! includes; see crates/voxscope-render/src/shaders.rs), so a shader typo fails here and not on a user's
//! machine. And every .wgsl file in shaders/ is part of some shader.

use std::collections::BTreeSet;
use std::path::PathBuf;

#[test]
fn every_shader_validates_and_every_file_is_used() {
    let mut used = BTreeSet::new();
    for shader in voxscope_render::shaders::ALL {
        let (name, source) = (shader.name, shader.source);
        let module = naga::front::wgsl::parse_str(source)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
        // The source is its files in order: the list this test reads is the one it was made of.
        let files: Vec<String> = shader
            .files
            .iter()
            .map(|file| {
                std::fs::read_to_string(
                    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                        .join("shaders")
                        .join(file),
                )
                .unwrap_or_else(|e| panic!("{name}: shaders/{file}: {e}"))
            })
            .collect();
        assert_eq!(source, files.concat(), "{name} is its files, concatenated");
        used.extend(shader.files.iter().map(|f| f.to_string()));
    }
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let on_disk: BTreeSet<String> = std::fs::read_dir(&dir)
        .expect("shaders/ exists")
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".wgsl"))
        .collect();
    assert_eq!(
        on_disk, used,
        "every .wgsl file is compiled into some shader"
    );
}
