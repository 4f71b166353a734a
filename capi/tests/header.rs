//! The committed header `capi/include/cablesense.h` is exactly what cbindgen
//! generates from `capi/src/lib.rs` with `capi/cbindgen.toml` (the cbindgen crate
//! is a dev-dependency, so this runs everywhere), and it declares every exported
//! function. Regenerate after an ABI change:
//! `cbindgen --config capi/cbindgen.toml --crate cablesense-capi --output capi/include/cablesense.h capi`
//! (or run this test with `CABLESENSE_BLESS=1`).

use std::collections::BTreeSet;
use std::path::Path;

fn dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `cs_*` names followed by `(` (declarations and definitions).
fn functions(text: &str) -> BTreeSet<String> {
    text.match_indices("cs_")
        .filter_map(|(i, _)| {
            let rest = &text[i..];
            let end = rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))?;
            let before = text[..i].chars().last();
            (rest[end..].starts_with('(')
                && !before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_'))
            .then(|| rest[..end].to_string())
        })
        .collect()
}

fn header_path() -> std::path::PathBuf {
    dir().join("include/cablesense.h")
}

fn generated() -> String {
    let config = cbindgen::Config::from_file(dir().join("cbindgen.toml")).unwrap();
    let bindings = cbindgen::Builder::new()
        .with_crate(dir())
        .with_config(config)
        .generate()
        .unwrap_or_else(|e| panic!("cbindgen failed: {e}"));
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).unwrap()
}

#[test]
fn committed_header_is_cbindgens_output() {
    let want = generated();
    if std::env::var_os("CABLESENSE_BLESS").is_some() {
        std::fs::write(header_path(), &want).unwrap();
    }
    let have = std::fs::read_to_string(header_path()).unwrap();
    if have != want {
        let line = have
            .lines()
            .zip(want.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| have.lines().count().min(want.lines().count()));
        panic!(
            "capi/include/cablesense.h is out of date (first difference at line {}: \
             committed {:?}, generated {:?}); regenerate it (see this file's header)",
            line + 1,
            have.lines().nth(line),
            want.lines().nth(line)
        );
    }
}

#[test]
fn header_declares_every_exported_function() {
    let src = std::fs::read_to_string(dir().join("src/lib.rs")).unwrap();
    let exported: BTreeSet<String> = src
        .split("extern \"C\" fn ")
        .skip(1)
        .filter_map(|s| s.split('(').next().map(str::to_string))
        .collect();
    assert!(exported.len() >= 25, "{exported:?}");
    let header = std::fs::read_to_string(header_path()).unwrap();
    assert_eq!(functions(&header), exported);
    for ty in [
        "CsCode",
        "CsSolveInfo",
        "CsEstimateInfo",
        "CsTendonInfo",
        "CsIkSettings",
        "CsIkInfo",
        "CsModel",
        "CsEstimator",
        "CsTendons",
    ] {
        assert!(header.contains(ty), "header lacks {ty}");
    }
}
