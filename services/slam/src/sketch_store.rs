//! The stored drawings, as the registry serves them: listed from their small files, their
//! stroke masks read on demand.
//!
//! A drawing is kept as its listing (size and lines extracted at upload) only; its mask is
//! read from `strokes.bin` when a session starts on it or its picture is drawn, and held
//! while anything uses it (a `Weak`). Opening a data dir of many drawings
//! reads small files and decodes no image, so the service answers at once. At most
//! `max_sketches` are stored.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, Weak};

use sketchslam_api::{ApiError, SketchInfo, SketchSummary, SketchUpload};
use sketchslam_engine::sketch::Sketch;
use sketchslam_engine::sketch::overlay::{encode_png, render_overlay};

use super::codec::{image_error, sketch_info};
use super::session::{lock, now_unix_ms};
use super::storage::{SketchMeta, SketchShape, Storage};

/// A stored drawing: its listing, and its processed drawing while something uses it.
struct StoredSketch {
    info: SketchInfo,
    shape: SketchShape,
    /// The drawing with its stroke mask, alive while a session or a request holds it.
    loaded: Mutex<Weak<Sketch>>,
}

impl StoredSketch {
    fn new(meta: &SketchMeta, shape: SketchShape, loaded: Weak<Sketch>) -> Self {
        Self {
            info: sketch_info(meta, &shape),
            shape,
            loaded: Mutex::new(loaded),
        }
    }

    /// The processed drawing: the one in use, or read back from `storage` (its lines as
    /// listed, its mask from `strokes.bin`).
    fn sketch(&self, storage: &Storage) -> Result<Arc<Sketch>, ApiError> {
        let mut loaded = lock(&self.loaded);
        if let Some(sketch) = loaded.upgrade() {
            return Ok(sketch);
        }
        let strokes = storage
            .read_strokes(&self.info.id, &self.shape)
            .map_err(|e| ApiError::internal(format!("reading sketch {}: {e}", self.info.id)))?;
        let sketch = Arc::new(Sketch {
            width_px: self.shape.width_px,
            height_px: self.shape.height_px,
            strokes,
            lines: self.shape.lines.clone(),
        });
        *loaded = Arc::downgrade(&sketch);
        Ok(sketch)
    }
}

/// The stored drawings of one service.
pub struct SketchStore {
    storage: Storage,
    max_sketches: usize,
    sketches: Mutex<BTreeMap<String, Arc<StoredSketch>>>,
}

impl SketchStore {
    /// Lists the drawings `storage` holds; those stored before `sketch.json` existed are
    /// processed once more (`processed_again`), and an unreadable one is skipped with a
    /// warning.
    pub fn open(storage: &Storage, max_sketches: usize) -> std::io::Result<Self> {
        let mut sketches = BTreeMap::new();
        for (meta, shape) in storage.load_sketches()? {
            let shape = match shape {
                Some(shape) => shape,
                None => match processed_again(storage, &meta) {
                    Ok(shape) => shape,
                    Err(e) => {
                        tracing::warn!(id = %meta.id, error = %e, "skipping stored sketch");
                        continue;
                    }
                },
            };
            let stored = StoredSketch::new(&meta, shape, Weak::new());
            sketches.insert(meta.id.clone(), Arc::new(stored));
        }
        Ok(Self {
            storage: storage.clone(),
            max_sketches,
            sketches: Mutex::new(sketches),
        })
    }

    /// Drawings stored.
    pub fn len(&self) -> usize {
        lock(&self.sketches).len()
    }

    /// True when none is stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn stored(&self, id: &str) -> Result<Arc<StoredSketch>, ApiError> {
        lock(&self.sketches)
            .get(id)
            .cloned()
            .ok_or_else(|| ApiError::sketch_not_found(id))
    }

    /// `too_many_sketches` when `sketches` holds `max_sketches` already.
    fn room_in(&self, sketches: &BTreeMap<String, Arc<StoredSketch>>) -> Result<(), ApiError> {
        if sketches.len() >= self.max_sketches {
            return Err(ApiError::conflict(
                "too_many_sketches",
                format!(
                    "{} sketches are stored, the limit is {}; delete one first",
                    sketches.len(),
                    self.max_sketches
                ),
            ));
        }
        Ok(())
    }

    /// Decodes `image`, extracts its lines and stores it under a new id with what the
    /// upload said of it.
    pub fn create(&self, upload: SketchUpload, image: &[u8]) -> Result<SketchInfo, ApiError> {
        self.room_in(&lock(&self.sketches))?;
        let sketch = Arc::new(Sketch::from_image_bytes(image).map_err(image_error)?);
        let meta = SketchMeta {
            id: uuid::Uuid::new_v4().to_string(),
            name: upload.name,
            created_unix_ms: now_unix_ms(),
            meters_per_pixel: upload.meters_per_pixel,
        };
        let mut sketches = lock(&self.sketches);
        // Again under the lock: uploads decode in parallel.
        self.room_in(&sketches)?;
        self.storage
            .save_sketch(&meta, image, &sketch)
            .map_err(|e| ApiError::internal(format!("storing sketch {}: {e}", meta.id)))?;
        let stored = StoredSketch::new(&meta, SketchShape::of(&sketch), Arc::downgrade(&sketch));
        let info = stored.info.clone();
        sketches.insert(meta.id.clone(), Arc::new(stored));
        drop(sketches);
        tracing::info!(id = %meta.id, lines = info.lines.len(), "sketch stored");
        Ok(info)
    }

    /// Every drawing's list entry, oldest first.
    pub fn list(&self) -> Vec<SketchSummary> {
        let mut list: Vec<SketchSummary> = lock(&self.sketches)
            .values()
            .map(|s| s.info.summary())
            .collect();
        list.sort_by(|a, b| (a.created_unix_ms, &a.id).cmp(&(b.created_unix_ms, &b.id)));
        list
    }

    /// A drawing's size and lines.
    pub fn info(&self, id: &str) -> Result<SketchInfo, ApiError> {
        Ok(self.stored(id)?.info.clone())
    }

    /// A drawing with its stroke mask (read back unless in use).
    pub fn sketch(&self, id: &str) -> Result<Arc<Sketch>, ApiError> {
        self.stored(id)?.sketch(&self.storage)
    }

    /// The drawing with its lines drawn and numbered, as a PNG.
    pub fn overlay_png(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        let sketch = self.sketch(id)?;
        Ok(encode_png(&render_overlay(&sketch)))
    }

    /// Removes a drawing (sessions on it keep their copy).
    pub fn delete(&self, id: &str) -> Result<(), ApiError> {
        if lock(&self.sketches).remove(id).is_none() {
            return Err(ApiError::sketch_not_found(id));
        }
        self.storage
            .delete_sketch(id)
            .map_err(|e| ApiError::internal(format!("deleting sketch {id}: {e}")))?;
        tracing::info!(%id, "sketch deleted");
        Ok(())
    }
}

/// A sketch stored before `sketch.json` and `strokes.bin` existed: its image decoded once
/// more and the two files added, so the next start reads them instead.
fn processed_again(storage: &Storage, meta: &SketchMeta) -> Result<SketchShape, String> {
    let image = storage
        .read_sketch_image(&meta.id)
        .map_err(|e| e.to_string())?;
    let sketch = Sketch::from_image_bytes(&image).map_err(|e| e.to_string())?;
    storage
        .save_processed_sketch(&meta.id, &sketch)
        .map_err(|e| e.to_string())?;
    tracing::info!(id = %meta.id, "stored sketch processed again and its lines kept");
    Ok(SketchShape::of(&sketch))
}
