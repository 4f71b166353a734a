//! `cablesense ... | head`: a reader that goes away early ends the command quietly
//! (exit code 0, nothing on stderr) instead of a panic ("failed printing to stdout:
//! Broken pipe") or an error message. Two paths: a command printing with `println!`
//! (the panic path) and the streaming `track` writing with `writeln!` (the error
//! path).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn assert_quiet(out: &std::process::Output, what: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("panicked") && !stderr.contains("error"),
        "{what}: stderr {stderr:?}"
    );
    assert!(stderr.trim().is_empty(), "{what}: stderr {stderr:?}");
    assert_eq!(out.status.code(), Some(0), "{what}: {:?}", out.status);
}

/// `println!` path, deterministic: stdout is a socket whose other end is closed
/// before the process starts, so its first write fails with EPIPE.
#[cfg(unix)]
#[test]
fn println_on_a_closed_stdout_exits_quietly() {
    use std::os::fd::OwnedFd;
    use std::os::unix::net::UnixStream;
    for args in [
        vec!["demo", "list"],
        vec!["solve", "data/scenes/demo_two_section.toml"],
    ] {
        let (ours, theirs) = UnixStream::pair().unwrap();
        drop(ours);
        let out = Command::new(env!("CARGO_BIN_EXE_cablesense"))
            .args(&args)
            .current_dir(root())
            .stdin(Stdio::null())
            .stdout(Stdio::from(OwnedFd::from(theirs)))
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        assert_quiet(&out, &args.join(" "));
    }
}

/// `track | head -n 1`: a real pipe, read for one line and then closed while
/// `track` still has rows to write.
#[test]
fn track_into_a_pipe_closed_after_one_line_exits_quietly() {
    let input = std::fs::read_to_string(root().join("data/measurements/track_demo.csv")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_cablesense"))
        .arg("track")
        .arg(Path::new("data/scenes/track_demo.toml"))
        .current_dir(root())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let mut stdout = child.stdout.take().unwrap();
    // the header and the first rows; read one output line, then close our end
    let mut lines = input.lines();
    let head: Vec<&str> = lines.by_ref().take(4).collect();
    writeln!(stdin, "{}", head.join("\n")).unwrap();
    stdin.flush().unwrap();
    let mut first = Vec::new();
    let mut byte = [0u8; 1];
    while std::io::Read::read(&mut stdout, &mut byte).unwrap() == 1 && byte[0] != b'\n' {
        first.push(byte[0]);
    }
    let first = String::from_utf8(first).unwrap();
    assert!(first.contains("\"estimate\""), "{first}");
    drop(stdout);
    // the rest: every row now writes into the closed pipe (track flushes per row);
    // the child may already be gone, so a failed write here is expected
    for line in lines {
        if writeln!(stdin, "{line}").is_err() {
            break;
        }
    }
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    assert_quiet(&out, "track | head -n 1");
}
