//! The occupancy grid as files and messages: the last stage of the pipeline, what the HTTP
//! API serves and what the evaluation reads back.
//!
//! - [`RosOccupancy`]: `nav_msgs/OccupancyGrid` data, row-major from the *bottom* row, −1
//!   unknown, 0–100 occupancy probability in percent;
//! - `map.pgm` + `map.yaml`: exactly the ROS `map_server` / `map_saver` pair — a binary
//!   P5 greymap whose first row is the *top* of the map, trinary: 0 occupied (p > 0.65),
//!   254 free (p < 0.196), 205 unknown; the YAML carries `image`, `resolution`, `origin`
//!   (pose of the lower-left pixel), `negate: 0`, `occupied_thresh: 0.65`,
//!   `free_thresh: 0.196`;
//! - a PNG with the same picture as the PGM.
//!
//! Reading back: [`parse_pgm`], [`parse_map_yaml`] and [`occupied_points_from_map`] apply
//! map_server's rule ([`pixel_is_occupied`], the workspace's one copy of it: `p = (255 − v)
//! / 255`, or `v / 255` with `negate`; occupied when `p > occupied_thresh`), so a saved map
//! yields exactly [`OccupancyGrid::occupied_points`] again; the evaluation scores maps
//! through [`occupied_points_in_order`].
//! again. All functions are O(cells) and never panic on malformed input.

use crate::error::EngineError;
use crate::mapping::grid::{FREE_THRESHOLD, OCCUPIED_THRESHOLD, OccupancyGrid};
use sketchslam_types::{Point2, Pose2};

/// PGM value of an occupied cell.
pub const PGM_OCCUPIED: u8 = 0;
/// PGM value of a free cell.
pub const PGM_FREE: u8 = 254;
/// PGM value of an unknown cell.
pub const PGM_UNKNOWN: u8 = 205;

/// A grid as `nav_msgs/OccupancyGrid` carries it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RosOccupancy {
    /// Number of columns.
    pub width: usize,
    /// Number of rows.
    pub height: usize,
    /// Side of a cell, meters.
    pub resolution_m: f64,
    /// Pose of the lower-left corner of cell (0, 0) in the map frame (heading 0).
    pub origin: Pose2,
    /// Row-major, bottom row first: −1 unknown (never observed), else the occupancy
    /// probability in percent, 0–100. Consistent with the grid's thresholds:
    /// `v ≥ 65` exactly when the cell is occupied (p > 0.65), `0 ≤ v ≤ 19` exactly when it
    /// is free (p < 0.196).
    pub data: Vec<i8>,
}

/// The `map.yaml` of a ROS map_server map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapYaml {
    /// The image file name, relative to the YAML file.
    pub image: String,
    /// Side of a pixel, meters.
    pub resolution_m: f64,
    /// Pose of the lower-left pixel in the map frame.
    pub origin: Pose2,
    /// True when white means occupied.
    pub negate: bool,
    /// Pixels with occupancy probability above it are occupied.
    pub occupied_thresh: f64,
    /// Pixels with occupancy probability below it are free.
    pub free_thresh: f64,
}

impl OccupancyGrid {
    /// Percent value of a cell as [`RosOccupancy::data`] documents it.
    fn ros_value(&self, col: usize, row: usize) -> i8 {
        if self.is_unknown(col, row) {
            return -1;
        }
        let p = self.probability(col, row);
        let v = (p * 100.0).round().clamp(0.0, 100.0) as i8;
        if self.is_occupied(col, row) {
            v.max(65)
        } else if self.is_free(col, row) {
            v.min(19)
        } else {
            v.clamp(20, 64)
        }
    }

    /// PGM value of a cell: 0 occupied, 254 free, 205 unknown (map_saver's trinary mode).
    fn pgm_value(&self, col: usize, row: usize) -> u8 {
        if self.is_occupied(col, row) {
            PGM_OCCUPIED
        } else if self.is_free(col, row) {
            PGM_FREE
        } else {
            PGM_UNKNOWN
        }
    }

    /// The grid as `nav_msgs/OccupancyGrid` data.
    pub fn to_ros_occupancy(&self) -> RosOccupancy {
        let mut data = Vec::with_capacity(self.width() * self.height());
        for row in 0..self.height() {
            for col in 0..self.width() {
                data.push(self.ros_value(col, row));
            }
        }
        let o = self.origin();
        RosOccupancy {
            width: self.width(),
            height: self.height(),
            resolution_m: self.resolution_m(),
            origin: Pose2::new(o.x, o.y, 0.0),
            data,
        }
    }

    /// The image pixels, first row = top of the map (largest y), as in the PGM.
    fn image_rows(&self) -> Vec<u8> {
        let (w, h) = (self.width(), self.height());
        let mut px = Vec::with_capacity(w * h);
        for img_row in 0..h {
            let row = h - 1 - img_row;
            for col in 0..w {
                px.push(self.pgm_value(col, row));
            }
        }
        px
    }

    /// The map as a binary PGM (P5) exactly as ROS `map_saver` writes it:
    /// `P5\n# CREATOR: sketchslam <res> m/pix\n<w> <h>\n255\n` then one byte per pixel, the
    /// first row being the top of the map; 0 occupied, 254 free, 205 unknown.
    pub fn to_pgm(&self) -> Vec<u8> {
        let mut out = format!(
            "P5\n# CREATOR: sketchslam {:.3} m/pix\n{} {}\n255\n",
            self.resolution_m(),
            self.width(),
            self.height()
        )
        .into_bytes();
        out.extend_from_slice(&self.image_rows());
        out
    }

    /// The `map.yaml` for the PGM saved as `image_file`. Numbers are written in Rust's
    /// shortest round-trip form, so reading them back gives the same `f64`s.
    pub fn to_yaml(&self, image_file: &str) -> String {
        let o = self.origin();
        // Quote the name if YAML could misread it.
        let plain = !image_file.is_empty()
            && image_file
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "._-/".contains(c));
        let image = if plain {
            image_file.to_string()
        } else {
            serde_json::to_string(image_file).unwrap_or_else(|_| "\"map.pgm\"".into())
        };
        format!(
            "image: {image}\nresolution: {:?}\norigin: [{:?}, {:?}, 0.0]\nnegate: 0\n\
             occupied_thresh: 0.65\nfree_thresh: 0.196\n",
            self.resolution_m(),
            o.x,
            o.y
        )
    }

    /// The same picture as [`OccupancyGrid::to_pgm`], as an 8-bit grayscale PNG.
    pub fn to_png(&self) -> Vec<u8> {
        use image::ImageEncoder;
        let mut out = Vec::new();
        let enc = image::codecs::png::PngEncoder::new(&mut out);
        let ok = enc
            .write_image(
                &self.image_rows(),
                self.width() as u32,
                self.height() as u32,
                image::ExtendedColorType::L8,
            )
            .is_ok();
        if ok { out } else { Vec::new() }
    }
}

fn map_err(msg: impl Into<String>) -> EngineError {
    EngineError::MapFormat(msg.into())
}

/// Reads a PGM greymap, binary (P5, maxval ≤ 255) or plain (P2), with `#` comments in the
/// header. Returns `(width, height, pixels)`, pixels row-major with the first row at the
/// top of the image; values are rescaled to 0–255 when maxval < 255.
pub fn parse_pgm(bytes: &[u8]) -> Result<(usize, usize, Vec<u8>), EngineError> {
    let mut pos = 0usize;
    // Next whitespace-separated header token, skipping comments.
    let token = |pos: &mut usize| -> Result<String, EngineError> {
        loop {
            while *pos < bytes.len() && bytes[*pos].is_ascii_whitespace() {
                *pos += 1;
            }
            if *pos < bytes.len() && bytes[*pos] == b'#' {
                while *pos < bytes.len() && bytes[*pos] != b'\n' && bytes[*pos] != b'\r' {
                    *pos += 1;
                }
                continue;
            }
            break;
        }
        let start = *pos;
        while *pos < bytes.len() && !bytes[*pos].is_ascii_whitespace() && bytes[*pos] != b'#' {
            *pos += 1;
        }
        if start == *pos {
            return Err(map_err("PGM header ends early"));
        }
        Ok(String::from_utf8_lossy(&bytes[start..*pos]).into_owned())
    };
    let magic = token(&mut pos)?;
    let binary = match magic.as_str() {
        "P5" => true,
        "P2" => false,
        other => return Err(map_err(format!("not a PGM (magic {other:?})"))),
    };
    let number = |pos: &mut usize, what: &str| -> Result<usize, EngineError> {
        let t = token(pos)?;
        t.parse::<usize>()
            .map_err(|_| map_err(format!("PGM {what} is not a number: {t:?}")))
    };
    let width = number(&mut pos, "width")?;
    let height = number(&mut pos, "height")?;
    let maxval = number(&mut pos, "maxval")?;
    if maxval == 0 || maxval > 255 {
        return Err(map_err(format!(
            "PGM maxval {maxval} unsupported (1..=255)"
        )));
    }
    let n = width
        .checked_mul(height)
        .filter(|&n| n <= 1 << 30)
        .ok_or_else(|| map_err("PGM too large"))?;
    let scale = |v: usize| -> u8 { ((v.min(maxval) * 255 + maxval / 2) / maxval) as u8 };
    let pixels = if binary {
        // Exactly one whitespace byte separates maxval from the raster.
        let start = pos + 1;
        let end = start
            .checked_add(n)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| map_err(format!("PGM raster short: want {n} bytes")))?;
        if maxval == 255 {
            bytes[start..end].to_vec()
        } else {
            bytes[start..end]
                .iter()
                .map(|&b| scale(b as usize))
                .collect()
        }
    } else {
        let mut px = Vec::with_capacity(n);
        for _ in 0..n {
            px.push(scale(number(&mut pos, "pixel")?));
        }
        px
    };
    Ok((width, height, pixels))
}

/// Reads a ROS map_server `map.yaml` (the flat `key: value` subset it uses, with `#`
/// comments and `origin: [x, y, yaw]`). `image`, `resolution` and `origin` are required;
/// `negate` defaults to 0, the thresholds to 0.65 / 0.196.
pub fn parse_map_yaml(text: &str) -> Result<MapYaml, EngineError> {
    let mut image = None;
    let mut resolution = None;
    let mut origin = None;
    let mut negate = false;
    let mut occupied_thresh = OCCUPIED_THRESHOLD;
    let mut free_thresh = FREE_THRESHOLD;
    let num = |key: &str, v: &str| -> Result<f64, EngineError> {
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| map_err(format!("{key}: not a finite number: {v:?}")))
    };
    for line in text.lines() {
        let line = match line.find('#') {
            // A '#' inside a quoted image name is not a comment.
            Some(i) if !line[..i].contains('"') && !line[..i].contains('\'') => &line[..i],
            _ => line,
        };
        let line = line.trim();
        if line.is_empty() || line == "---" {
            continue;
        }
        let Some((key, value)) = line.split_once(':') else {
            return Err(map_err(format!("not a `key: value` line: {line:?}")));
        };
        let value = value.trim();
        match key.trim() {
            "image" => {
                let v = value
                    .strip_prefix('"')
                    .and_then(|v| v.strip_suffix('"'))
                    .or_else(|| value.strip_prefix('\'').and_then(|v| v.strip_suffix('\'')))
                    .unwrap_or(value);
                image = Some(v.to_string());
            }
            "resolution" => resolution = Some(num("resolution", value)?),
            "origin" => {
                let inner = value
                    .strip_prefix('[')
                    .and_then(|v| v.strip_suffix(']'))
                    .ok_or_else(|| map_err("origin: expected [x, y, yaw]"))?;
                let parts: Vec<f64> = inner
                    .split(',')
                    .map(|p| num("origin", p))
                    .collect::<Result<_, _>>()?;
                if parts.len() != 3 {
                    return Err(map_err("origin: expected 3 numbers"));
                }
                origin = Some(Pose2::new(parts[0], parts[1], parts[2]));
            }
            "negate" => negate = num("negate", value)? != 0.0,
            "occupied_thresh" => occupied_thresh = num("occupied_thresh", value)?,
            "free_thresh" => free_thresh = num("free_thresh", value)?,
            // Other keys map_server knows (mode, ...) do not change the geometry.
            _ => {}
        }
    }
    let resolution_m = resolution.ok_or_else(|| map_err("resolution missing"))?;
    if resolution_m <= 0.0 {
        return Err(map_err("resolution must be positive"));
    }
    Ok(MapYaml {
        image: image.ok_or_else(|| map_err("image missing"))?,
        resolution_m,
        origin: origin.ok_or_else(|| map_err("origin missing"))?,
        negate,
        occupied_thresh,
        free_thresh,
    })
}

/// The order in which [`occupied_points_in_order`] lists the pixels of a map read back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowOrder {
    /// Bottom row of the map first (the grid's order, [`OccupancyGrid::occupied_points`]).
    BottomFirst,
    /// Top row first, the image's own order (the PGM's first row first).
    TopFirst,
}

/// map_server's rule for one pixel value `v` of a map: `p = (255 − v)/255` (`v/255` with
/// `negate`) is the occupancy probability, and the pixel is occupied when
/// `p > occupied_thresh`.
pub fn pixel_is_occupied(meta: &MapYaml, v: u8) -> bool {
    let v = v as f64;
    let p = if meta.negate {
        v / 255.0
    } else {
        (255.0 - v) / 255.0
    };
    p > meta.occupied_thresh
}

/// Centres of the occupied pixels of a map read back from disk, in the map frame:
/// pixel `(c, r)` of the image (row 0 at the top) is cell `(c, height − 1 − r)`, occupied
/// by [`pixel_is_occupied`]. Bottom row first, like [`OccupancyGrid::occupied_points`].
pub fn occupied_points_from_map(
    meta: &MapYaml,
    width: usize,
    height: usize,
    pixels: &[u8],
) -> Vec<Point2> {
    occupied_points_in_order(meta, width, height, pixels, RowOrder::BottomFirst)
}

/// [`occupied_points_from_map`] with the rows in `order` (left to right within a row).
/// The points are the same; a sum over them depends on the order in its last bits.
pub fn occupied_points_in_order(
    meta: &MapYaml,
    width: usize,
    height: usize,
    pixels: &[u8],
    order: RowOrder,
) -> Vec<Point2> {
    let mut out = Vec::new();
    if pixels.len() < width.saturating_mul(height) {
        return out;
    }
    let r = meta.resolution_m;
    for k in 0..height {
        let row = match order {
            RowOrder::BottomFirst => k,
            RowOrder::TopFirst => height - 1 - k,
        };
        let img_row = height - 1 - row;
        for col in 0..width {
            if pixel_is_occupied(meta, pixels[img_row * width + col]) {
                let local = Point2::new((col as f64 + 0.5) * r, (row as f64 + 0.5) * r);
                out.push(if meta.origin.heading_rad == 0.0 {
                    Point2::new(meta.origin.x + local.x, meta.origin.y + local.y)
                } else {
                    meta.origin.transform_point(&local)
                });
            }
        }
    }
    out
}
