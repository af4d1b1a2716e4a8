//! The picture of a run: the built map over the truth, with both trajectories.
//!
//! Drawn at the truth image's resolution in the world frame: free space white, true walls
//! light grey, occupied map cells (moved by the trajectory alignment) red, the true
//! trajectory green, the aligned estimate blue.

use crate::metrics::{StampedPose, WallGrid};
use image::{Rgb, RgbImage};
use sketchslam_types::{Point2, Pose2};

const FREE: Rgb<u8> = Rgb([255, 255, 255]);
const WALL: Rgb<u8> = Rgb([200, 200, 200]);
const MAP: Rgb<u8> = Rgb([220, 30, 30]);
const TRUTH: Rgb<u8> = Rgb([20, 160, 40]);
const ESTIMATE: Rgb<u8> = Rgb([30, 60, 220]);

/// Draws the overlay.
pub fn draw(
    walls: &WallGrid,
    occupied_map_frame: &[Point2],
    estimate: &[StampedPose],
    truth: &[StampedPose],
    alignment: &Pose2,
) -> RgbImage {
    let mut img = RgbImage::from_fn(walls.width as u32, walls.height as u32, |c, r| {
        if walls.is_wall(c as usize, r as usize) {
            WALL
        } else {
            FREE
        }
    });
    let plot = |img: &mut RgbImage, p: Point2, colour: Rgb<u8>, radius: i64| {
        if let Some((c, r)) = walls.pixel_of(p) {
            for dr in -radius..=radius {
                for dc in -radius..=radius {
                    let (x, y) = (c as i64 + dc, r as i64 + dr);
                    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
                        img.put_pixel(x as u32, y as u32, colour);
                    }
                }
            }
        }
    };
    for p in occupied_map_frame {
        plot(&mut img, alignment.transform_point(p), MAP, 0);
    }
    for t in truth {
        plot(&mut img, t.pose.position(), TRUTH, 1);
    }
    for e in estimate {
        plot(
            &mut img,
            alignment.transform_point(&e.pose.position()),
            ESTIMATE,
            0,
        );
    }
    img
}
