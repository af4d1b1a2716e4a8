//! The data dir: sketches and stopped sessions, kept across restarts.
//!
//! ```text
//! <data-dir>/sketches/<id>/image      the uploaded bytes, as sent
//! <data-dir>/sketches/<id>/meta.json  id, name, upload time
//! <data-dir>/sessions/<id>/map.pgm, map.yaml, map.png, map.json, trajectory.csv
//! <data-dir>/sessions/<id>/sketch-trajectory.json                       (sketch sessions)
//! <data-dir>/sessions/<id>/registration.json, sketch-overlay.png,
//!                          sketch-in-map.json, sketch-in-map.png       (once registered)
//! <data-dir>/sessions/<id>/meta.json  final status and pose (written last)
//! ```
//!
//! Every file is written to a temporary name and renamed, and `meta.json` last, so a crash
//! leaves either a complete entry or one that is skipped (with a warning) on load.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sketchslam_api::{PoseResponse, SessionInfo};

/// Metadata of a stored sketch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SketchMeta {
    /// Sketch id.
    pub id: String,
    /// Name given at upload.
    pub name: Option<String>,
    /// Upload time, ms since the epoch.
    pub created_unix_ms: u64,
}

/// Metadata of a stopped session.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionMeta {
    /// The final status.
    pub info: SessionInfo,
    /// The final pose.
    pub pose: PoseResponse,
}

/// The files of a stopped session.
#[derive(Debug, Clone)]
pub struct SessionFiles {
    /// `map.pgm`.
    pub map_pgm: Vec<u8>,
    /// `map.yaml` (naming `map.pgm`).
    pub map_yaml: String,
    /// `map.png`.
    pub map_png: Vec<u8>,
    /// `map.json` (the API's occupancy JSON).
    pub map_json: Vec<u8>,
    /// `trajectory.csv`.
    pub trajectory_csv: String,
    /// `sketch-trajectory.json` (the API's trajectory on the drawing; `sketch` sessions).
    pub sketch_trajectory_json: Option<Vec<u8>>,
    /// The map laid on the drawing (`sketch` sessions whose map could be registered).
    pub registration: Option<RegistrationFiles>,
}

/// The files of a stopped session's map-on-drawing registration.
#[derive(Debug, Clone)]
pub struct RegistrationFiles {
    /// `registration.json` (the API's `RegistrationInfo`: the warp's parameters).
    pub registration_json: Vec<u8>,
    /// `sketch-overlay.png`.
    pub sketch_overlay_png: Vec<u8>,
    /// `sketch-in-map.json` (the API's `SketchInMapResponse`).
    pub sketch_in_map_json: Vec<u8>,
    /// `sketch-in-map.png`.
    pub sketch_in_map_png: Vec<u8>,
}

/// The data dir.
#[derive(Debug, Clone)]
pub struct Storage {
    root: PathBuf,
}

/// True for names we create (UUIDs): never a path separator or `..`.
fn safe_id(id: &str) -> bool {
    !id.is_empty()
        && id.len() <= 64
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

fn invalid_id(id: &str) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, format!("unsafe id {id:?}"))
}

/// Writes `bytes` to `path` through a temporary file and a rename.
fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = path.with_extension("tmp");
    fs::write(&tmp, bytes)?;
    fs::rename(&tmp, path)
}

impl Storage {
    /// Opens (creating it if needed) the data dir at `root`.
    pub fn open(root: &Path) -> io::Result<Self> {
        fs::create_dir_all(root.join("sketches"))?;
        fs::create_dir_all(root.join("sessions"))?;
        Ok(Self {
            root: root.to_path_buf(),
        })
    }

    /// The data dir.
    pub fn root(&self) -> &Path {
        &self.root
    }

    fn sketch_dir(&self, id: &str) -> io::Result<PathBuf> {
        if safe_id(id) {
            Ok(self.root.join("sketches").join(id))
        } else {
            Err(invalid_id(id))
        }
    }

    fn session_dir(&self, id: &str) -> io::Result<PathBuf> {
        if safe_id(id) {
            Ok(self.root.join("sessions").join(id))
        } else {
            Err(invalid_id(id))
        }
    }

    /// Stores an uploaded sketch.
    pub fn save_sketch(&self, meta: &SketchMeta, image: &[u8]) -> io::Result<()> {
        let dir = self.sketch_dir(&meta.id)?;
        fs::create_dir_all(&dir)?;
        write_atomic(&dir.join("image"), image)?;
        let json = serde_json::to_vec_pretty(meta).map_err(io::Error::other)?;
        write_atomic(&dir.join("meta.json"), &json)
    }

    /// Removes a stored sketch.
    pub fn delete_sketch(&self, id: &str) -> io::Result<()> {
        let dir = self.sketch_dir(id)?;
        match fs::remove_dir_all(dir) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            other => other,
        }
    }

    /// Every complete stored sketch with its image bytes; incomplete ones are skipped.
    pub fn load_sketches(&self) -> io::Result<Vec<(SketchMeta, Vec<u8>)>> {
        let mut out = Vec::new();
        for entry in fs::read_dir(self.root.join("sketches"))? {
            let dir = entry?.path();
            let loaded = (|| -> Result<_, String> {
                let meta = fs::read(dir.join("meta.json")).map_err(|e| e.to_string())?;
                let meta: SketchMeta = serde_json::from_slice(&meta).map_err(|e| e.to_string())?;
                if !safe_id(&meta.id) {
                    return Err(format!("unsafe id {:?}", meta.id));
                }
                let image = fs::read(dir.join("image")).map_err(|e| e.to_string())?;
                Ok((meta, image))
            })();
            match loaded {
                Ok(item) => out.push(item),
                Err(e) => {
                    tracing::warn!(dir = %dir.display(), error = %e, "skipping stored sketch")
                }
            }
        }
        out.sort_by(|a, b| (a.0.created_unix_ms, &a.0.id).cmp(&(b.0.created_unix_ms, &b.0.id)));
        Ok(out)
    }

    /// Stores a stopped session's files, `meta.json` last.
    pub fn save_session(&self, meta: &SessionMeta, files: &SessionFiles) -> io::Result<()> {
        let dir = self.session_dir(&meta.info.id)?;
        fs::create_dir_all(&dir)?;
        write_atomic(&dir.join("map.pgm"), &files.map_pgm)?;
        write_atomic(&dir.join("map.yaml"), files.map_yaml.as_bytes())?;
        write_atomic(&dir.join("map.png"), &files.map_png)?;
        write_atomic(&dir.join("map.json"), &files.map_json)?;
        write_atomic(&dir.join("trajectory.csv"), files.trajectory_csv.as_bytes())?;
        if let Some(json) = &files.sketch_trajectory_json {
            write_atomic(&dir.join("sketch-trajectory.json"), json)?;
        }
        if let Some(r) = &files.registration {
            write_atomic(&dir.join("registration.json"), &r.registration_json)?;
            write_atomic(&dir.join("sketch-overlay.png"), &r.sketch_overlay_png)?;
            write_atomic(&dir.join("sketch-in-map.json"), &r.sketch_in_map_json)?;
            write_atomic(&dir.join("sketch-in-map.png"), &r.sketch_in_map_png)?;
        }
        let json = serde_json::to_vec_pretty(meta).map_err(io::Error::other)?;
        write_atomic(&dir.join("meta.json"), &json)
    }

    /// Every complete stopped session; incomplete ones are skipped.
    pub fn load_sessions(&self) -> io::Result<Vec<SessionMeta>> {
        let mut out = Vec::new();
        for entry in fs::read_dir(self.root.join("sessions"))? {
            let dir = entry?.path();
            let loaded = fs::read(dir.join("meta.json"))
                .map_err(|e| e.to_string())
                .and_then(|m| serde_json::from_slice::<SessionMeta>(&m).map_err(|e| e.to_string()));
            match loaded {
                Ok(meta) if safe_id(&meta.info.id) => out.push(meta),
                Ok(meta) => tracing::warn!(id = %meta.info.id, "skipping session with unsafe id"),
                Err(e) => {
                    tracing::warn!(dir = %dir.display(), error = %e, "skipping stored session")
                }
            }
        }
        out.sort_by(|a, b| {
            (a.info.created_unix_ms, &a.info.id).cmp(&(b.info.created_unix_ms, &b.info.id))
        });
        Ok(out)
    }

    /// One file of a stopped session (`map.png`, `trajectory.csv`, ...).
    pub fn read_session_file(&self, id: &str, name: &str) -> io::Result<Vec<u8>> {
        fs::read(self.session_dir(id)?.join(name))
    }
}
