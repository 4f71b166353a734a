//! `capi/include/cablesense.h` (hand-written) declares exactly the functions that
//! `capi/src/lib.rs` exports. When `cbindgen` is installed, its output for this
//! crate is generated too and must declare the same functions and types.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

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

fn header() -> String {
    std::fs::read_to_string(dir().join("include/cablesense.h")).unwrap()
}

#[test]
fn header_declares_every_exported_function() {
    let src = std::fs::read_to_string(dir().join("src/lib.rs")).unwrap();
    let exported: BTreeSet<String> = src
        .split("extern \"C\" fn ")
        .skip(1)
        .filter_map(|s| s.split('(').next().map(str::to_string))
        .collect();
    assert!(exported.len() >= 15, "{exported:?}");
    assert_eq!(functions(&header()), exported);
}

#[test]
fn header_matches_cbindgen_when_installed() {
    let Ok(out) = Command::new("cbindgen")
        .args(["--lang", "c", "--crate", "cablesense-capi"])
        .current_dir(dir())
        .output()
    else {
        eprintln!("cbindgen not installed: skipped (cargo install cbindgen --locked)");
        return;
    };
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let generated = String::from_utf8(out.stdout).unwrap();
    assert_eq!(functions(&generated), functions(&header()));
    for ty in [
        "CsCode",
        "CsSolveInfo",
        "CsEstimateInfo",
        "CsModel",
        "CsEstimator",
    ] {
        assert!(generated.contains(ty), "cbindgen output lacks {ty}");
        assert!(header().contains(ty), "header lacks {ty}");
    }
}
