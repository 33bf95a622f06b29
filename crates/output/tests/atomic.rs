//! Atomic writes: no temporary files left behind, never a half-written file.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use simkit_output::atomic::{AtomicFile, write_atomic};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("simkit-output-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn writes_creates_parents_and_leaves_no_temp_file() {
    let dir = tmp("atomic-ok");
    let path = dir.join("a/b/out.txt");
    write_atomic(&path, |w| w.write_all(b"first")).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"first");
    write_atomic(&path, |w| w.write_all(b"second, longer")).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"second, longer");
    assert_eq!(entries(&dir.join("a/b")), ["out.txt"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn failing_writer_keeps_previous_file() {
    let dir = tmp("atomic-fail");
    let path = dir.join("data.csv");
    write_atomic(&path, |w| w.write_all(b"good")).unwrap();
    let err = write_atomic(&path, |w| {
        w.write_all(b"half of a new fi")?;
        Err(io::Error::other("simulated failure"))
    })
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("simulated failure") && msg.contains("data.csv"),
        "{msg}"
    );
    assert_eq!(std::fs::read(&path).unwrap(), b"good");
    assert_eq!(entries(&dir), ["data.csv"]);

    // Dropping an uncommitted AtomicFile behaves the same.
    let mut f = AtomicFile::create(&path).unwrap();
    f.write_all(b"partial").unwrap();
    assert_eq!(entries(&dir).len(), 2); // target + temporary
    drop(f);
    assert_eq!(std::fs::read(&path).unwrap(), b"good");
    assert_eq!(entries(&dir), ["data.csv"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_paths_are_errors() {
    assert!(write_atomic("/", |w| w.write_all(b"x")).is_err());
    let dir = tmp("atomic-dir");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    // Renaming a file over a directory fails; the temporary file is cleaned up.
    let err = write_atomic(dir.join("sub"), |w| w.write_all(b"x")).unwrap_err();
    assert!(err.to_string().contains("sub"), "{err}");
    assert_eq!(entries(&dir), ["sub"]);
    std::fs::remove_dir_all(&dir).unwrap();
}
