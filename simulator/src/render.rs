//! A picture of a scenario, for people: the truth world, the path, the start and a few
//! simulated scans.
//!
//! `simulator render` writes it to a PNG; it is the quickest way to see that a hand-written
//! scenario is what its author meant (path in the corridors, start facing the right way,
//! scans hitting the walls where they should). One image pixel per world cell, y up.
//!
//! Colours: walls dark grey, free space white, path blue, start green (a disc and a heading
//! tick), scan poses orange, scan returns red.

use crate::error::SimError;
use crate::lidar::Lidar;
use crate::motion::Motion;
use crate::scenario::Scenario;
use crate::simulation::{RENDER_STREAM, stream_rng};
use crate::world::World;
use image::{Rgb, RgbImage};
use sketchslam_types::Point2;
use std::path::Path;

const WALL: Rgb<u8> = Rgb([60, 60, 60]);
const FREE: Rgb<u8> = Rgb([255, 255, 255]);
const PATH: Rgb<u8> = Rgb([40, 90, 220]);
const START: Rgb<u8> = Rgb([20, 170, 60]);
const SCAN_POSE: Rgb<u8> = Rgb([240, 140, 0]);
const SCAN_POINT: Rgb<u8> = Rgb([220, 20, 20]);

/// Draws `scenario`: the world, the path, the start and `scans_to_draw` scans taken at
/// evenly spaced times along the path (with the scenario's noise, seeded from its seed).
/// Cost: one pass over the image plus `scans_to_draw · beams` ray casts.
pub fn render_scenario(scenario: &Scenario, scans_to_draw: usize) -> Result<RgbImage, SimError> {
    let world = scenario.load_world()?;
    Ok(render_world(scenario, &world, scans_to_draw))
}

/// Like [`render_scenario`] with an already loaded world.
pub fn render_world(scenario: &Scenario, world: &World, scans_to_draw: usize) -> RgbImage {
    let (w, h) = (world.width(), world.height());
    let mut canvas = Canvas {
        img: RgbImage::new(w as u32, h as u32),
        resolution_m: world.resolution_m(),
    };
    for (u, v, px) in canvas.img.enumerate_pixels_mut() {
        let j = h as i64 - 1 - v as i64;
        *px = if world.is_wall_cell(u as i64, j) {
            WALL
        } else {
            FREE
        };
    }

    // Path.
    let start = scenario.robot.start;
    let mut from = start.position();
    for &to in &scenario.robot.path {
        canvas.line(from, to, 1, PATH);
        from = to;
    }

    // Scans.
    let motion = Motion::new(&scenario.robot);
    let lidar = Lidar::new(&scenario.lidar);
    let mut rng = stream_rng(scenario.seed, RENDER_STREAM);
    for k in 0..scans_to_draw {
        let t_s = motion.duration_s() * (k as f64 + 0.5) / scans_to_draw as f64;
        let pose = motion.pose_at(t_s);
        let ranges_m = lidar.scan(world, pose, &mut rng);
        let sensor = lidar.sensor_pose(pose);
        for (i, &r) in ranges_m.iter().enumerate() {
            if r.is_finite() {
                let a = lidar.beam_angle_rad(i);
                let local = Point2::new(r as f64 * a.cos(), r as f64 * a.sin());
                canvas.dot(sensor.transform_point(&local), 1, SCAN_POINT);
            }
        }
        canvas.dot(pose.position(), 4, SCAN_POSE);
    }

    // Start on top: a disc and a tick along the heading.
    let px_m = world.resolution_m();
    let tick = Point2::new(12.0 * px_m, 0.0);
    canvas.line(start.position(), start.transform_point(&tick), 1, START);
    canvas.dot(start.position(), 6, START);
    canvas.img
}

/// Saves a rendered picture as PNG.
pub fn save_png(img: &RgbImage, path: &Path) -> Result<(), SimError> {
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| SimError::Io {
            file: path.to_path_buf(),
            action: "cannot write PNG",
            source: std::io::Error::other(e),
        })
}

/// An image in world coordinates.
struct Canvas {
    img: RgbImage,
    resolution_m: f64,
}

impl Canvas {
    /// Pixel (u, v) of a world point, v from the top.
    fn pixel(&self, p: Point2) -> (f64, f64) {
        (
            p.x / self.resolution_m,
            self.img.height() as f64 - p.y / self.resolution_m,
        )
    }

    /// A filled square of half-width `radius_px` centred on `p`; clipped to the image.
    fn dot(&mut self, p: Point2, radius_px: i64, colour: Rgb<u8>) {
        let (u, v) = self.pixel(p);
        if !(u.is_finite() && v.is_finite()) {
            return;
        }
        let (cu, cv) = (u.floor() as i64, v.floor() as i64);
        let (w, h) = (self.img.width() as i64, self.img.height() as i64);
        for dv in -radius_px..=radius_px {
            for du in -radius_px..=radius_px {
                if du * du + dv * dv > radius_px * radius_px + radius_px {
                    continue;
                }
                let (x, y) = (cu + du, cv + dv);
                if (0..w).contains(&x) && (0..h).contains(&y) {
                    self.img.put_pixel(x as u32, y as u32, colour);
                }
            }
        }
    }

    /// A line of half-width `radius_px`, drawn as dots every half pixel.
    fn line(&mut self, a: Point2, b: Point2, radius_px: i64, colour: Rgb<u8>) {
        let len_px = a.distance(&b) / self.resolution_m;
        if !len_px.is_finite() {
            return;
        }
        let n = (2.0 * len_px).ceil().max(1.0) as usize;
        for k in 0..=n {
            let f = k as f64 / n as f64;
            let p = Point2::new(a.x + f * (b.x - a.x), a.y + f * (b.y - a.y));
            self.dot(p, radius_px, colour);
        }
    }
}
