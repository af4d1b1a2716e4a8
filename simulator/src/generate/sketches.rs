//! The sketches of a generated world: how many (2 or 3), which one is photographed, what
//! each person drew (a small room forgotten, doors drawn open or shut, a short wall left
//! out), and where they marked the start (a few pixels and degrees off the truth).
//!
//! Called by [`super::generate`]; strokes with [`super::drawing`], photographs with
//! [`super::photo`], writes with [`super::files`].

use super::floor::{AreaKind, Floor};
use super::mapping::{DrawingMap, METERS_PER_PIXEL};
use super::route::Route;
use super::{GeneratedDrawing, drawing, files, photo};
use crate::error::GenerateError;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;
use std::path::Path;

/// Draws 2 or 3 sketches (one photographed), writes their images, and marks the start on
/// each.
pub fn draw_all(
    floor: &Floor,
    route: &Route,
    out_dir: &Path,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<GeneratedDrawing>, GenerateError> {
    let count = rng.random_range(2..=3);
    let photographed = rng.random_range(0..count);
    let mut out = Vec::new();
    for k in 0..count {
        let name = ["A", "B", "C"][k].to_string();
        let photo = k == photographed;
        let map = DrawingMap::random([floor.width_m, floor.height_m], photo, rng);
        let mut how = Vec::new();
        let (sx, sy) = map.stretches();
        let pct = |v: &[f64]| {
            v.iter()
                .map(|s| format!("{:+.0} %", (s - 1.0) * 100.0))
                .collect::<Vec<_>>()
                .join(", ")
        };
        how.push(format!("x drawn {}, y drawn {}", pct(&sx), pct(&sy)));

        // What the person drew: every area but maybe one small room; doors open or shut.
        let mut areas = vec![true; floor.areas.len()];
        let rooms: Vec<usize> = (0..floor.areas.len())
            .filter(|&i| floor.areas[i].kind == AreaKind::Room)
            .collect();
        if !rooms.is_empty() && rng.random_bool(0.4) {
            let left_out = rooms[rng.random_range(0..rooms.len())];
            areas[left_out] = false;
            let c = floor.areas[left_out].rect.centre();
            how.push(format!("the room at ({:.0}, {:.0}) m left out", c.x, c.y));
        }
        let open = rng.random_bool(0.6);
        how.push(if open {
            "door gaps left open".into()
        } else {
            "doors drawn shut".into()
        });
        let doors: Vec<bool> = floor
            .doors
            .iter()
            .map(|d| d.areas.iter().all(|&a| areas[a]) && (open != rng.random_bool(0.15)))
            .collect();
        let mut segments = drawing::outline(floor, &areas, &doors);
        let before = segments.len();
        segments.retain(|(a, b)| {
            let len = a.distance(b);
            !(0.5..2.5).contains(&len) || !rng.random_bool(0.05)
        });
        if segments.len() < before {
            how.push(format!("{} short walls left out", before - segments.len()));
        }
        let pen = drawing::Pen::random(rng.random_range(2.0..3.0), rng);
        let flat = drawing::render(&map, &segments, &pen);
        let corners_m = corners(floor, &areas, &segments);

        let file_name;
        if photo {
            let (img, p) = photo::photograph(&flat, &map, rng);
            file_name = format!("sketch-{}.jpg", name.to_lowercase());
            files::write_jpeg(&out_dir.join(&file_name), &img, p.quality)?;
            how.push(format!(
                "photographed: turned {}°, uneven light (paper down to {:.0} % white), blur {:.1} px, JPEG q{}",
                map.rotate_deg,
                p.darkest * 100.0,
                p.blur_px,
                p.quality
            ));
        } else {
            file_name = format!("sketch-{}.png", name.to_lowercase());
            files::write_png(&out_dir.join(&file_name), &flat)?;
        }

        // The person's mark: within ~0.7 m-equivalent and 5° of the truth.
        let (u, v, heading) = map.world_to_drawing(&route.start);
        let (r_px, dir) = (
            rng.random_range(0.0..0.7) / METERS_PER_PIXEL,
            rng.random_range(0.0..std::f64::consts::TAU),
        );
        let (size_u, size_v) = map.rotated_size();
        let mark_u = (u + r_px * dir.cos()).clamp(0.0, size_u - 1.0);
        let mark_v = (v + r_px * dir.sin()).clamp(0.0, size_v - 1.0);
        let mark_deg = heading.to_degrees() + rng.random_range(-5.0..5.0);
        let round1 = |x: f64| (x * 10.0).round() / 10.0;
        out.push(GeneratedDrawing {
            name,
            file_name,
            map,
            photographed: photo,
            start_marked: [round1(mark_u), round1(mark_v), round1(mark_deg)],
            corners_m,
            how: how.join("; "),
        });
    }
    Ok(out)
}

/// Corners of drawn rooms and halls whose wall corner (grown to the middle of the wall, as
/// [`drawing::outline`] draws it) is the end of a drawn stroke: the room's free corner
/// lies within a wall's thickness of ink.
fn corners(floor: &Floor, areas: &[bool], segments: &[drawing::Segment]) -> Vec<Point2> {
    let ends: Vec<Point2> = segments.iter().flat_map(|&(a, b)| [a, b]).collect();
    let near = floor.wall_m * 0.75 + 0.05;
    let mut out = Vec::new();
    for (k, a) in floor.areas.iter().enumerate() {
        if !areas[k]
            || !matches!(
                a.kind,
                AreaKind::Room | AreaKind::MeetingRoom | AreaKind::Hall
            )
        {
            continue;
        }
        for c in a.rect.corners() {
            if ends.iter().any(|e| e.distance(&c) <= near) {
                out.push(c);
            }
        }
    }
    out
}
