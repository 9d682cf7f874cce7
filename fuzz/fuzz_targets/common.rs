//! Shared by the fuzz targets: a map loaded from bytes the way
//! `Network::load` does (model, then grid, R-tree and topology), and a
//! scratch file per process for the readers that take a path.

use std::path::{Path, PathBuf};
use waymark::network::{load_model, LoadOptions, Network};

/// Loads `bytes` as the map file `name`; every error is fine, a panic is not.
#[allow(dead_code)]
pub fn load_map(name: &str, bytes: &[u8]) {
    let path = Path::new(name);
    if let Ok(model) = load_model(path, bytes, &LoadOptions::default()) {
        if let Ok(net) = Network::from_model(model, None) {
            let _ = net.defects(1.0);
        }
    }
}

/// A scratch folder of this process: in memory (`/dev/shm`) where there is
/// one, else in the system's temporary folder.
#[allow(dead_code)]
pub fn scratch() -> PathBuf {
    let shm = Path::new("/dev/shm");
    let base = if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    };
    let d = base.join(format!("waymark-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("scratch folder");
    d
}
