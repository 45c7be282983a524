//! Helpers shared by the end-to-end tests of fipt-rs.
use std::path::PathBuf;

/// The shared folder beside the repository (`../shared`), or `$FIPT_SHARED`; None when absent
/// (a user's clone does not have it: tests that need it skip with a message).
pub fn shared_dir() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("FIPT_SHARED") {
        let p = PathBuf::from(p);
        return p.is_dir().then_some(p);
    }
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared");
    p.is_dir().then_some(p)
}

/// The Mitsuba-rendered studio scene, or None (with a message on stderr) when absent.
pub fn studio_scene() -> Option<PathBuf> {
    let p = shared_dir().map(|s| s.join("scenes/studio-mitsuba"));
    match p {
        Some(p) if p.join("scene.obj").is_file() => Some(p),
        _ => {
            eprintln!("SKIPPED: ../shared/scenes/studio-mitsuba not found (set FIPT_SHARED to the shared folder to run this test)");
            None
        }
    }
}

/// A fresh temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fipt-e2e-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}
