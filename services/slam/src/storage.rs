//! The data dir: sketches, stopped sessions and the checkpoints of running ones, kept
//! across restarts.
//!
//! ```text
//! <data-dir>/sketches/<id>/image        the uploaded bytes, as sent
//! <data-dir>/sketches/<id>/sketch.json  size and lines extracted at upload (SketchShape)
//! <data-dir>/sketches/<id>/strokes.bin  the stroke mask, one bit a pixel (row-major,
//!                                       pixel i in bit i % 8 of byte i / 8)
//! <data-dir>/sketches/<id>/meta.json    id, name, upload time (written last)
//! <data-dir>/sessions/<id>/map.pgm, map.yaml, map.png, map.json, trajectory.csv
//! <data-dir>/sessions/<id>/sketch-trajectory.json                       (sketch sessions)
//! <data-dir>/sessions/<id>/registration.json, sketch-overlay.png,
//!                          sketch-in-map.json, sketch-in-map.png       (once registered)
//! <data-dir>/sessions/<id>/meta.json  status and pose (written last): final once stopped,
//!                                     the last checkpoint's while running (registration
//!                                     files are written at the stop only)
//! ```
//!
//! Every file is written to a temporary file of its own (a unique name, so two writers never
//! share one), flushed to disk and renamed over its final name; the folder is flushed after
//! the renames, and `meta.json` is written last. A crash therefore leaves either a complete
//! entry or one without `meta.json`, and perhaps temporary files. [`Storage::open`] cleans
//! both up and reports them: temporary files are removed, and an entry without a readable
//! `meta.json` is moved to `<data-dir>/incomplete/` (kept for a person to look at, never
//! served).

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use fixedbitset::FixedBitSet;
use serde::{Deserialize, Serialize};
use sketchslam_api::{PoseResponse, SessionInfo};
use sketchslam_engine::sketch::{Sketch, SketchLine};

/// Metadata of a stored sketch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SketchMeta {
    /// Sketch id.
    pub id: String,
    /// Name given at upload.
    pub name: Option<String>,
    /// Upload time, ms since the epoch.
    pub created_unix_ms: u64,
    /// The scale declared at upload, meters per pixel (absent in versions before
    /// 2026-12-04).
    #[serde(default)]
    pub meters_per_pixel: Option<f64>,
}

/// What the service keeps of a processed drawing besides its stroke mask (`sketch.json`):
/// enough to list it and to show its lines without decoding the image again. The lines
/// are those extracted at upload, so a later version's extraction never renumbers the
/// lines of a drawing already in use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SketchShape {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// The extracted lines.
    pub lines: Vec<SketchLine>,
}

impl SketchShape {
    /// The shape of a processed drawing.
    pub fn of(sketch: &Sketch) -> Self {
        Self {
            width_px: sketch.width_px,
            height_px: sketch.height_px,
            lines: sketch.lines.clone(),
        }
    }

    /// Pixels in the image.
    pub fn pixels(&self) -> usize {
        self.width_px as usize * self.height_px as usize
    }
}

/// A stored sketch as the service lists it: its metadata and, unless it was stored by a
/// version before 2026-12-03 (only the image then), its shape.
pub type ListedSketch = (SketchMeta, Option<SketchShape>);

/// A stroke mask as `strokes.bin` holds it: pixel `i` in bit `i % 8` of byte `i / 8`.
pub fn mask_to_bytes(mask: &FixedBitSet) -> Vec<u8> {
    let mut bytes = vec![0u8; mask.len().div_ceil(8)];
    for i in mask.ones() {
        bytes[i / 8] |= 1 << (i % 8);
    }
    bytes
}

/// [`mask_to_bytes`] undone for a mask of `pixels` bits; `None` when the length is not
/// `pixels` rounded up to bytes, or a bit past the last pixel is set.
pub fn mask_from_bytes(bytes: &[u8], pixels: usize) -> Option<FixedBitSet> {
    if bytes.len() != pixels.div_ceil(8) {
        return None;
    }
    let mut mask = FixedBitSet::with_capacity(pixels);
    for (k, &byte) in bytes.iter().enumerate().filter(|(_, b)| **b != 0) {
        for bit in 0..8 {
            if byte >> bit & 1 == 1 {
                let i = k * 8 + bit;
                if i >= pixels {
                    return None;
                }
                mask.insert(i);
            }
        }
    }
    Some(mask)
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

/// Temporary files start with this, so that a crash's leftovers can be told from data.
const TEMP_PREFIX: &str = ".sketchslam-tmp-";

/// Writes `bytes` to `path` through a temporary file of its own in the same folder, flushed
/// to disk before it is renamed over `path`: a reader sees the old file or the new one,
/// never a mix, and concurrent writers of one folder never write into each other's file.
/// The folder itself is flushed by the caller ([`sync_dir`]) once its files are renamed.
fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = path
        .parent()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "a path without a folder"))?;
    let mut tmp = tempfile::Builder::new()
        .prefix(TEMP_PREFIX)
        .tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// Flushes a folder's entries (the renames into it) to disk.
fn sync_dir(dir: &Path) -> io::Result<()> {
    fs::File::open(dir)?.sync_all()
}

/// What [`Storage::open`] found of an earlier crash and cleaned up.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Leftovers {
    /// Temporary files removed (paths as they were).
    pub temp_files_removed: Vec<PathBuf>,
    /// Entries without a readable `meta.json`, moved from where they were to here.
    pub incomplete_moved: Vec<(PathBuf, PathBuf)>,
}

impl Leftovers {
    /// True when nothing needed cleaning.
    pub fn is_empty(&self) -> bool {
        self.temp_files_removed.is_empty() && self.incomplete_moved.is_empty()
    }
}

/// True for a file name a crashed write may have left: our temporary files, and the
/// `*.tmp` names of versions before 2026-12-03.
fn is_temp_name(name: &str) -> bool {
    name.starts_with(TEMP_PREFIX) || name.ends_with(".tmp")
}

impl Storage {
    /// Opens (creating it if needed) the data dir at `root`, and cleans up what a crash left
    /// in it (module doc), logging each item and returning them.
    pub fn open(root: &Path) -> io::Result<(Self, Leftovers)> {
        fs::create_dir_all(root.join("sketches"))?;
        fs::create_dir_all(root.join("sessions"))?;
        let storage = Self {
            root: root.to_path_buf(),
        };
        let leftovers = storage.clean_leftovers()?;
        for path in &leftovers.temp_files_removed {
            tracing::warn!(file = %path.display(), "removed a half-written temporary file");
        }
        for (from, to) in &leftovers.incomplete_moved {
            tracing::warn!(
                from = %from.display(),
                to = %to.display(),
                "moved an entry without a readable meta.json aside"
            );
        }
        Ok((storage, leftovers))
    }

    /// Removes temporary files from every entry and moves entries without a readable
    /// `meta.json` to `incomplete/<kind>-<folder>`.
    fn clean_leftovers(&self) -> io::Result<Leftovers> {
        let mut out = Leftovers::default();
        for kind in ["sketches", "sessions"] {
            let parent = self.root.join(kind);
            for entry in fs::read_dir(&parent)? {
                let entry = entry?;
                let path = entry.path();
                let name = entry.file_name().to_string_lossy().into_owned();
                if !entry.file_type()?.is_dir() {
                    if is_temp_name(&name) {
                        fs::remove_file(&path)?;
                        out.temp_files_removed.push(path);
                    }
                    continue;
                }
                for file in fs::read_dir(&path)? {
                    let file = file?;
                    if is_temp_name(&file.file_name().to_string_lossy()) {
                        fs::remove_file(file.path())?;
                        out.temp_files_removed.push(file.path());
                    }
                }
                let readable = fs::read(path.join("meta.json"))
                    .ok()
                    .is_some_and(|m| serde_json::from_slice::<serde_json::Value>(&m).is_ok());
                if !readable {
                    let aside = self.root.join("incomplete");
                    fs::create_dir_all(&aside)?;
                    let mut to = aside.join(format!("{kind}-{name}"));
                    let mut n = 1;
                    while to.exists() {
                        n += 1;
                        to = aside.join(format!("{kind}-{name}-{n}"));
                    }
                    fs::rename(&path, &to)?;
                    out.incomplete_moved.push((path, to));
                }
            }
            sync_dir(&parent)?;
        }
        Ok(out)
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

    /// Stores an uploaded sketch: its image as sent and what was extracted from it
    /// (`meta.json` last).
    pub fn save_sketch(&self, meta: &SketchMeta, image: &[u8], sketch: &Sketch) -> io::Result<()> {
        let dir = self.sketch_dir(&meta.id)?;
        fs::create_dir_all(&dir)?;
        sync_dir(&self.root.join("sketches"))?;
        write_atomic(&dir.join("image"), image)?;
        self.write_processed(&dir, sketch)?;
        let json = serde_json::to_vec_pretty(meta).map_err(io::Error::other)?;
        write_atomic(&dir.join("meta.json"), &json)?;
        sync_dir(&dir)
    }

    /// Adds `sketch.json` and `strokes.bin` to a sketch stored before they existed.
    pub fn save_processed_sketch(&self, id: &str, sketch: &Sketch) -> io::Result<()> {
        let dir = self.sketch_dir(id)?;
        self.write_processed(&dir, sketch)
    }

    /// `strokes.bin`, then `sketch.json` (whose presence says both are there).
    fn write_processed(&self, dir: &Path, sketch: &Sketch) -> io::Result<()> {
        write_atomic(&dir.join("strokes.bin"), &mask_to_bytes(&sketch.strokes))?;
        sync_dir(dir)?;
        let shape = serde_json::to_vec(&SketchShape::of(sketch)).map_err(io::Error::other)?;
        write_atomic(&dir.join("sketch.json"), &shape)?;
        sync_dir(dir)
    }

    /// A stored sketch's image as uploaded.
    pub fn read_sketch_image(&self, id: &str) -> io::Result<Vec<u8>> {
        fs::read(self.sketch_dir(id)?.join("image"))
    }

    /// A stored sketch's stroke mask (`shape` says its size).
    pub fn read_strokes(&self, id: &str, shape: &SketchShape) -> io::Result<FixedBitSet> {
        let bytes = fs::read(self.sketch_dir(id)?.join("strokes.bin"))?;
        mask_from_bytes(&bytes, shape.pixels()).ok_or_else(|| {
            io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "strokes.bin of sketch {id}: {} bytes do not hold a {} × {} mask",
                    bytes.len(),
                    shape.width_px,
                    shape.height_px
                ),
            )
        })
    }

    /// Removes a stored sketch.
    pub fn delete_sketch(&self, id: &str) -> io::Result<()> {
        let dir = self.sketch_dir(id)?;
        match fs::remove_dir_all(dir) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            other => other,
        }
    }

    /// Every complete stored sketch with its shape (small files only: no image is read or
    /// decoded, so a data dir of many drawings opens at once); incomplete ones are skipped.
    /// A shape that cannot be read is `None`, as for an entry stored before shapes were.
    pub fn load_sketches(&self) -> io::Result<Vec<ListedSketch>> {
        let mut out = Vec::new();
        for entry in fs::read_dir(self.root.join("sketches"))? {
            let dir = entry?.path();
            let loaded = (|| -> Result<_, String> {
                let meta = fs::read(dir.join("meta.json")).map_err(|e| e.to_string())?;
                let meta: SketchMeta = serde_json::from_slice(&meta).map_err(|e| e.to_string())?;
                if !safe_id(&meta.id) {
                    return Err(format!("unsafe id {:?}", meta.id));
                }
                let shape = fs::read(dir.join("sketch.json")).ok().and_then(|json| {
                    serde_json::from_slice::<SketchShape>(&json)
                        .inspect_err(|e| {
                            tracing::warn!(dir = %dir.display(), error = %e, "unreadable sketch.json: the image will be decoded again")
                        })
                        .ok()
                });
                Ok((meta, shape))
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
        sync_dir(&self.root.join("sessions"))?;
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
        // Every file is on disk before the meta.json that makes the entry complete.
        sync_dir(&dir)?;
        let json = serde_json::to_vec_pretty(meta).map_err(io::Error::other)?;
        write_atomic(&dir.join("meta.json"), &json)?;
        sync_dir(&dir)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh data dir under the system's temporary folder.
    fn data_dir(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new()
            .prefix(&format!("sketchslam-storage-{name}-"))
            .tempdir()
            .unwrap()
    }

    fn sketch(id: &str) -> SketchMeta {
        SketchMeta {
            id: id.into(),
            name: Some("A".into()),
            created_unix_ms: 1,
            meters_per_pixel: None,
        }
    }

    /// A 5 × 3 drawing: one stroke along its middle row, one line on it.
    fn drawing() -> Sketch {
        let flags: Vec<bool> = (0..15).map(|i| (5..10).contains(&i)).collect();
        Sketch {
            width_px: 5,
            height_px: 3,
            strokes: Sketch::mask_from_flags(&flags),
            lines: vec![SketchLine::new(
                0,
                sketchslam_types::Point2::new(0.5, 1.5),
                sketchslam_types::Point2::new(4.5, 1.5),
            )],
        }
    }

    #[test]
    fn a_stroke_mask_packs_eight_pixels_a_byte_and_reads_back() {
        // Pixels 5..10 set: byte 0 = bits 5, 6, 7 (0b1110_0000), byte 1 = bits 0, 1.
        let mask = drawing().strokes;
        assert_eq!(mask_to_bytes(&mask), vec![0b1110_0000, 0b0000_0011]);
        assert_eq!(mask_from_bytes(&[0b1110_0000, 0b0000_0011], 15), Some(mask));
        // The wrong length, or a bit set past the last pixel, is not a mask of 15 pixels.
        assert_eq!(mask_from_bytes(&[0, 0, 0], 15), None);
        assert_eq!(mask_from_bytes(&[0, 0b1000_0000], 15), None);
    }

    #[test]
    fn a_stored_sketch_reads_back_its_mask_and_lines_without_its_image() {
        let dir = data_dir("shape");
        let (storage, _) = Storage::open(dir.path()).unwrap();
        let drawn = drawing();
        storage
            .save_sketch(&sketch("s1"), b"not even an image", &drawn)
            .unwrap();
        let listed = storage.load_sketches().unwrap();
        let shape = listed[0].1.clone().unwrap();
        assert_eq!(shape, SketchShape::of(&drawn));
        assert_eq!(storage.read_strokes("s1", &shape).unwrap(), drawn.strokes);
        // A mask cut short is an error naming the file, not a drawing of another size.
        let bin = dir.path().join("sketches/s1/strokes.bin");
        fs::write(&bin, [0u8]).unwrap();
        let err = storage.read_strokes("s1", &shape).unwrap_err();
        assert!(err.to_string().contains("strokes.bin"), "{err}");
    }

    #[test]
    fn concurrent_writers_of_one_folder_never_mix_their_files() {
        // Before 2026-12-03 every file of a folder went through one `<stem>.tmp`: two
        // saves at once wrote PNG bytes into map.yaml. Twelve writers, four files each.
        let dir = data_dir("concurrent");
        let folder = dir.path().join("entry");
        fs::create_dir_all(&folder).unwrap();
        let names = ["map.pgm", "map.yaml", "map.png", "map.json"];
        std::thread::scope(|scope| {
            for _ in 0..12 {
                scope.spawn(|| {
                    for name in names {
                        let bytes = name.repeat(20_000);
                        write_atomic(&folder.join(name), bytes.as_bytes()).unwrap();
                    }
                });
            }
        });
        for name in names {
            let bytes = fs::read(folder.join(name)).unwrap();
            assert_eq!(bytes, name.repeat(20_000).into_bytes(), "{name}");
        }
        // No temporary file is left behind.
        assert_eq!(fs::read_dir(&folder).unwrap().count(), names.len());
    }

    #[test]
    fn opening_cleans_what_a_crash_left_and_keeps_what_was_complete() {
        let dir = data_dir("leftovers");
        let (storage, clean) = Storage::open(dir.path()).unwrap();
        assert!(clean.is_empty());
        storage
            .save_sketch(&sketch("kept"), b"image bytes", &drawing())
            .unwrap();
        // A crash during writes: a temporary file in a complete entry, an old-style
        // `map.tmp`, and a session whose meta.json was never written.
        let kept = dir.path().join("sketches/kept");
        fs::write(kept.join(format!("{TEMP_PREFIX}x1")), b"half").unwrap();
        let torn = dir.path().join("sessions/torn");
        fs::create_dir_all(&torn).unwrap();
        fs::write(torn.join("map.pgm"), b"P5 half a map").unwrap();
        fs::write(torn.join("map.tmp"), b"half").unwrap();
        // A meta.json cut short is not readable either.
        let cut = dir.path().join("sketches/cut");
        fs::create_dir_all(&cut).unwrap();
        fs::write(cut.join("meta.json"), b"{\"id\": \"cu").unwrap();

        let (storage, clean) = Storage::open(dir.path()).unwrap();
        assert_eq!(clean.temp_files_removed.len(), 2, "{clean:?}");
        assert!(clean.temp_files_removed.iter().all(|p| !p.exists()));
        let moved: Vec<&Path> = clean
            .incomplete_moved
            .iter()
            .map(|(_, to)| to.as_path())
            .collect();
        assert_eq!(moved.len(), 2, "{clean:?}");
        let aside = dir.path().join("incomplete");
        assert!(moved.contains(&aside.join("sessions-torn").as_path()));
        assert!(moved.contains(&aside.join("sketches-cut").as_path()));
        // Moved aside with what it held, not deleted.
        assert_eq!(
            fs::read(aside.join("sessions-torn/map.pgm")).unwrap(),
            b"P5 half a map"
        );
        assert!(!torn.exists() && !cut.exists());
        // The complete sketch is intact and the only one listed.
        let sketches = storage.load_sketches().unwrap();
        assert_eq!(sketches.len(), 1);
        assert_eq!(sketches[0].0, sketch("kept"));
        assert_eq!(sketches[0].1, Some(SketchShape::of(&drawing())));
        assert_eq!(storage.read_sketch_image("kept").unwrap(), b"image bytes");
        assert!(storage.load_sessions().unwrap().is_empty());
        // A second open finds nothing more to clean.
        assert!(Storage::open(dir.path()).unwrap().1.is_empty());
    }
}
