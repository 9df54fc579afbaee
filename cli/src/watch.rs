//! `peeltrim view --watch`: the model file is polled (its modification time
//! and length, every [`POLL`]) and reloaded when it has changed and then
//! stayed the same for one poll (a save caught halfway, the file truncated
//! and not yet written, is not loaded), through the same
//! loader as the first load (a `.scad` file is exported again by `openscad`;
//! the cache is keyed by content). Only the named file is watched: files it
//! imports, includes or names (OBJ meshes of a TOML scene) are not.
//!
//! Polling rather than file-system notifications: one `stat` a tenth of a
//! second costs nothing, behaves the same on every platform and file system
//! (network mounts included), and sees editors that save by renaming a new
//! file over the old one.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use peeltrim::scene::Scene;

/// How often the file is checked.
pub const POLL: Duration = Duration::from_millis(100);

/// Loads a scene from the watched path (the same loader as the first load).
pub type Loader = Box<dyn FnMut(&Path) -> Result<Scene, String>>;

/// A watched model file.
pub struct Watch {
    path: PathBuf,
    stamp: Option<(SystemTime, u64)>,
    /// A change seen at the last poll, loaded when the next one sees it still.
    pending: Option<(SystemTime, u64)>,
    load: Loader,
}

/// A reload: when the file was saved, how long the load took, and its result.
pub struct Reload {
    pub saved: SystemTime,
    pub load_ms: f64,
    pub result: Result<Scene, String>,
}

fn stamp(path: &Path) -> Option<(SystemTime, u64)> {
    let m = std::fs::metadata(path).ok()?;
    Some((m.modified().ok()?, m.len()))
}

impl Watch {
    /// Watches `path` from its present state.
    pub fn new(path: &Path, load: Loader) -> Self {
        Watch {
            path: path.to_path_buf(),
            stamp: stamp(path),
            pending: None,
            load,
        }
    }

    /// The watched path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The reload, when the file changed since it was last loaded and is the
    /// same as at the last call (a file that vanished, as in the middle of a
    /// save by rename, is waited for).
    pub fn poll(&mut self) -> Option<Reload> {
        let now = stamp(&self.path)?;
        if Some(now) == self.stamp {
            self.pending = None;
            return None;
        }
        if self.pending != Some(now) {
            self.pending = Some(now);
            return None;
        }
        self.stamp = Some(now);
        self.pending = None;
        let t = std::time::Instant::now();
        let result = (self.load)(&self.path);
        Some(Reload {
            saved: now.0,
            load_ms: t.elapsed().as_secs_f64() * 1e3,
            result,
        })
    }
}

/// Milliseconds from `saved` to now (0 when the clock disagrees).
pub fn ms_since(saved: SystemTime) -> f64 {
    SystemTime::now()
        .duration_since(saved)
        .map_or(0.0, |d| d.as_secs_f64() * 1e3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reloads_when_the_file_changes_only() {
        let dir = std::env::temp_dir().join(format!("peeltrim-watch-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("m.csg");
        std::fs::write(&f, "cube();").unwrap();
        let count = std::rc::Rc::new(std::cell::Cell::new(0));
        let c = count.clone();
        let mut w = Watch::new(
            &f,
            Box::new(move |p| {
                c.set(c.get() + 1);
                Err(format!("{} loaded", p.display()))
            }),
        );
        assert!(w.poll().is_none());
        std::fs::write(&f, "cube(size = [2, 2, 2]);").unwrap();
        assert!(w.poll().is_none(), "a change waits one poll");
        std::fs::write(&f, "cube(size = [30, 2, 2]);").unwrap();
        assert!(w.poll().is_none(), "a change that goes on waits again");
        let r = w.poll().expect("a changed length is a change");
        assert!(r.result.unwrap_err().ends_with("m.csg loaded"));
        assert!(w.poll().is_none());
        std::fs::remove_file(&f).unwrap();
        assert!(w.poll().is_none(), "a vanished file is waited for");
        assert_eq!(count.get(), 1);
        std::fs::remove_dir_all(&dir).ok();
    }
}
