//! A picture the API serves again and again while a session maps (the map, the map over the
//! drawing): its PNG, the map frame it is drawn in, and the entity tag that lets a client
//! that already holds it get `304 Not Modified` instead of the bytes.
//!
//! The web page polls `map.png` about once a second with `If-None-Match`; a robot standing
//! still changes nothing, and nothing is resent. The frame travels in headers of the same
//! response ([`MAP_RESOLUTION_HEADER`], [`MAP_ORIGIN_X_HEADER`], [`MAP_ORIGIN_Y_HEADER`]) so
//! that a client drawing the trajectory over the picture never pairs one map's pixels with
//! another's origin.

use std::hash::{Hash, Hasher};

use axum::http::{HeaderMap, HeaderName, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};

/// Meters per pixel of the map picture.
pub const MAP_RESOLUTION_HEADER: HeaderName = HeaderName::from_static("x-map-resolution-m");
/// Map-frame x of the picture's bottom-left corner, meters (ROS `map.yaml`'s `origin[0]`).
pub const MAP_ORIGIN_X_HEADER: HeaderName = HeaderName::from_static("x-map-origin-x-m");
/// Map-frame y of the picture's bottom-left corner, meters (ROS `map.yaml`'s `origin[1]`).
pub const MAP_ORIGIN_Y_HEADER: HeaderName = HeaderName::from_static("x-map-origin-y-m");

/// Where a map picture lies in the map frame: ROS `map.yaml`'s `resolution` and `origin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapFrame {
    /// Meters per pixel.
    pub resolution_m: f64,
    /// Map-frame x of the bottom-left corner, meters.
    pub origin_x_m: f64,
    /// Map-frame y of the bottom-left corner, meters.
    pub origin_y_m: f64,
}

impl MapFrame {
    /// The frame a ROS `map.yaml` names (`resolution: r` and `origin: [x, y, yaw]` lines, as
    /// `map_saver` and this service write them); `None` when either is missing or unreadable.
    pub fn from_ros_yaml(yaml: &str) -> Option<MapFrame> {
        let mut resolution = None;
        let mut origin = None;
        for line in yaml.lines() {
            if let Some(r) = line.strip_prefix("resolution:") {
                resolution = r.trim().parse::<f64>().ok();
            } else if let Some(o) = line.strip_prefix("origin:") {
                let inner = o.trim().strip_prefix('[')?.strip_suffix(']')?;
                let mut parts = inner.split(',').map(|p| p.trim().parse::<f64>());
                match (parts.next(), parts.next()) {
                    (Some(Ok(x)), Some(Ok(y))) => origin = Some((x, y)),
                    _ => return None,
                }
            }
        }
        let (origin_x_m, origin_y_m) = origin?;
        Some(MapFrame {
            resolution_m: resolution.filter(|r| *r > 0.0)?,
            origin_x_m,
            origin_y_m,
        })
    }
}

/// A PNG the API serves with an entity tag, and the map frame when it is a map.
#[derive(Debug, Clone, PartialEq)]
pub struct TaggedPng {
    /// The PNG bytes.
    pub png: Vec<u8>,
    /// The map frame of the picture (a map or a picture in map pixels), if any.
    pub frame: Option<MapFrame>,
}

impl TaggedPng {
    /// A picture without a frame.
    pub fn new(png: Vec<u8>) -> Self {
        Self { png, frame: None }
    }

    /// A map picture in `frame`.
    pub fn in_frame(png: Vec<u8>, frame: MapFrame) -> Self {
        Self {
            png,
            frame: Some(frame),
        }
    }

    /// A strong entity tag: a 64-bit hash of the bytes and the frame. Equal pictures get the
    /// same tag in one process; a collision would need 2³² versions of one map.
    pub fn etag(&self) -> String {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.png.hash(&mut h);
        if let Some(f) = self.frame {
            f.resolution_m.to_bits().hash(&mut h);
            f.origin_x_m.to_bits().hash(&mut h);
            f.origin_y_m.to_bits().hash(&mut h);
        }
        format!("\"{:016x}\"", h.finish())
    }

    /// `304 Not Modified` when `request` carries this picture's tag in `If-None-Match`
    /// (or `*`), else `200` with the PNG; both with the tag, `Cache-Control: no-cache` (a
    /// live map changes: revalidate every time) and the frame headers.
    pub fn respond(self, request: &HeaderMap) -> Response {
        let etag = self.etag();
        let matched = request
            .get_all(header::IF_NONE_MATCH)
            .iter()
            .filter_map(|v| v.to_str().ok())
            .flat_map(|v| v.split(','))
            .map(str::trim)
            .any(|t| t == "*" || t == etag || t.strip_prefix("W/") == Some(etag.as_str()));
        let mut headers = HeaderMap::new();
        if let Ok(v) = HeaderValue::from_str(&etag) {
            headers.insert(header::ETAG, v);
        }
        headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
        if let Some(f) = self.frame {
            for (name, value) in [
                (MAP_RESOLUTION_HEADER, f.resolution_m),
                (MAP_ORIGIN_X_HEADER, f.origin_x_m),
                (MAP_ORIGIN_Y_HEADER, f.origin_y_m),
            ] {
                // Rust's shortest round-trip form: the client reads back the same f64.
                if let Ok(v) = HeaderValue::from_str(&format!("{value:?}")) {
                    headers.insert(name, v);
                }
            }
        }
        if matched {
            return (StatusCode::NOT_MODIFIED, headers).into_response();
        }
        headers.insert(header::CONTENT_TYPE, HeaderValue::from_static("image/png"));
        (headers, self.png).into_response()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_frame_of_a_ros_yaml() {
        let yaml = "image: map.pgm\nresolution: 0.05\norigin: [-12.5, 3.25, 0.0]\nnegate: 0\n";
        assert_eq!(
            MapFrame::from_ros_yaml(yaml),
            Some(MapFrame {
                resolution_m: 0.05,
                origin_x_m: -12.5,
                origin_y_m: 3.25
            })
        );
        assert_eq!(MapFrame::from_ros_yaml("resolution: 0.05\n"), None);
        assert_eq!(
            MapFrame::from_ros_yaml("resolution: 0\norigin: [0, 0, 0]\n"),
            None
        );
        assert_eq!(
            MapFrame::from_ros_yaml("resolution: 0.1\norigin: [a, 0, 0]\n"),
            None
        );
    }

    #[test]
    fn the_tag_follows_bytes_and_frame() {
        let frame = MapFrame {
            resolution_m: 0.05,
            origin_x_m: 0.0,
            origin_y_m: 0.0,
        };
        let a = TaggedPng::in_frame(vec![1, 2, 3], frame);
        assert_eq!(a.etag(), a.clone().etag());
        assert_ne!(a.etag(), TaggedPng::in_frame(vec![1, 2, 4], frame).etag());
        let moved = MapFrame {
            origin_x_m: -0.05,
            ..frame
        };
        assert_ne!(a.etag(), TaggedPng::in_frame(vec![1, 2, 3], moved).etag());
    }

    #[test]
    fn a_matching_if_none_match_gets_304_without_the_bytes() {
        let png = TaggedPng::new(vec![9; 10]);
        let tag = png.etag();
        let mut req = HeaderMap::new();
        req.insert(
            header::IF_NONE_MATCH,
            HeaderValue::from_str(&format!("\"other\", {tag}")).unwrap(),
        );
        let r = png.clone().respond(&req);
        assert_eq!(r.status(), StatusCode::NOT_MODIFIED);
        assert_eq!(r.headers()[header::ETAG], tag.as_str());
        let r = png.respond(&HeaderMap::new());
        assert_eq!(r.status(), StatusCode::OK);
        assert_eq!(r.headers()[header::CONTENT_TYPE], "image/png");
    }
}
