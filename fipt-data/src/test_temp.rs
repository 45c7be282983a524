//! A scratch folder for the data crates' unit tests, removed when dropped.
use std::path::PathBuf;

/// A temporary folder (unique per process, call and time), removed when dropped.
pub struct Temp(pub PathBuf);

impl Default for Temp {
    fn default() -> Temp {
        Temp::new()
    }
}

impl Temp {
    pub fn new() -> Temp {
        static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let t = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap();
        let name = format!("fipt-core-test-{}-{n}-{}", std::process::id(), t.as_nanos());
        let p = std::env::temp_dir().join(name);
        std::fs::create_dir_all(&p).unwrap();
        Temp(p)
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
