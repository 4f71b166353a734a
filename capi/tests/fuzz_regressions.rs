//! Replays the committed inputs of the `capi` fuzz target (`fuzz/seeds/capi/`,
//! `fuzz/regressions/capi/`) through its check (`fuzz/fuzz_targets/shared_capi.rs`),
//! like `tests/fuzz_regressions.rs` does for the library's targets (the check calls
//! this crate's functions, so it lives here). A failure names the file; reproduce it
//! with `cargo fuzz run --sanitizer none capi fuzz/regressions/capi/<file>`.

#[path = "../../fuzz/fuzz_targets/shared_capi.rs"]
mod shared_capi;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

#[test]
fn capi_inputs() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz");
    let mut files = Vec::new();
    for kind in ["seeds", "regressions"] {
        let Ok(dir) = std::fs::read_dir(root.join(kind).join("capi")) else {
            continue;
        };
        for entry in dir {
            let path = entry.expect("readable directory entry").path();
            let is_doc = path
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("README"));
            if path.is_file() && !is_doc {
                files.push(path);
            }
        }
    }
    files.sort();
    assert!(files.len() >= 6, "capi: {} committed inputs", files.len());
    let failed: Vec<String> = files
        .iter()
        .filter(|path| {
            let data = std::fs::read(path).expect("readable fuzz input");
            catch_unwind(AssertUnwindSafe(|| shared_capi::check_capi(&data))).is_err()
        })
        .map(|path| path.display().to_string())
        .collect();
    assert!(failed.is_empty(), "capi: failing inputs: {failed:#?}");
}
