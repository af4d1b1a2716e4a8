//! Corrections the generated OpenAPI document needs to say what goes over the wire, applied
//! after utoipa has built it from the handlers' attributes (one place, rather than
//! repeated on every handler):
//!
//! - `401` on every operation that needs the token (all but `/healthz`), whose security is
//!   declared empty instead;
//! - binary bodies (`image/*`, PGM) as `string`/`binary` rather than arrays of integers,
//!   and the upload's `image/jpeg` beside `image/png`;
//! - `413` on every operation with a request body; `408`, `414` and `431` (the HTTP layer's,
//!   without a body) on every operation;
//! - the event stream as its events (`event`, `id`, `data`), not the JSON wrapper the Rust
//!   type serializes to, and `map.yaml` as the object a YAML reader gets.

use utoipa::Modify;
use utoipa::openapi::path::Operation;
use utoipa::openapi::schema::{KnownFormat, ObjectBuilder, SchemaFormat, Type};
use utoipa::openapi::{Content, OpenApi, Ref, RefOr, Response, Schema};

/// Paths that answer without the token.
const PUBLIC_PATHS: [&str; 1] = ["/healthz"];

/// The [`Modify`] that applies the corrections.
pub struct WireFixes;

impl Modify for WireFixes {
    fn modify(&self, openapi: &mut OpenApi) {
        for (path, item) in openapi.paths.paths.iter_mut() {
            let public = PUBLIC_PATHS.contains(&path.as_str());
            for op in [
                &mut item.get,
                &mut item.post,
                &mut item.put,
                &mut item.delete,
            ]
            .into_iter()
            .flatten()
            {
                fix_operation(op, public);
            }
        }
    }
}

fn fix_operation(op: &mut Operation, public: bool) {
    if public {
        // An empty list overrides the document's global bearer requirement.
        op.security = Some(Vec::new());
    } else {
        op.responses
            .responses
            .entry("401".into())
            .or_insert_with(|| {
                error_response("Missing or wrong bearer token (when the service has one)")
            });
    }
    for (status, description) in [
        (
            "408",
            "The request was not complete within --request-timeout-s (no body)",
        ),
        (
            "414",
            "The request line is longer than the HTTP layer reads (no body)",
        ),
        (
            "431",
            "Headers too large or more than 100 of them (no body)",
        ),
    ] {
        op.responses
            .responses
            .entry(status.into())
            .or_insert_with(|| RefOr::T(Response::new(description)));
    }
    if let Some(body) = op.request_body.as_mut() {
        for (content_type, content) in body.content.iter_mut() {
            if is_binary(content_type) {
                content.schema = Some(binary());
            }
        }
        if body.content.contains_key("image/png") && !body.content.contains_key("image/jpeg") {
            body.content
                .insert("image/jpeg".into(), Content::new(Some(binary())));
        }
        op.responses
            .responses
            .entry("413".into())
            .or_insert_with(|| error_response("The body is larger than --max-body-bytes"));
    }
    for response in op.responses.responses.values_mut() {
        let RefOr::T(response) = response else {
            continue;
        };
        for (content_type, content) in response.content.iter_mut() {
            if is_binary(content_type) {
                content.schema = Some(binary());
            } else if content_type == "text/event-stream" {
                content.schema = Some(event_stream());
            } else if content_type == "application/yaml" {
                content.schema = Some(map_yaml());
            }
        }
    }
}

fn is_binary(content_type: &str) -> bool {
    content_type.starts_with("image/") || content_type == "application/octet-stream"
}

fn error_response(description: &str) -> RefOr<Response> {
    RefOr::T(
        Response::builder()
            .description(description)
            .content(
                "application/json",
                Content::new(Some(Ref::from_schema_name("ErrorBody"))),
            )
            .build(),
    )
}

fn binary() -> RefOr<Schema> {
    RefOr::T(Schema::Object(
        ObjectBuilder::new()
            .schema_type(Type::String)
            .format(Some(SchemaFormat::KnownFormat(KnownFormat::Binary)))
            .build(),
    ))
}

/// One server-sent event, as SSE clients (and contract testers) parse the stream.
fn event_stream() -> RefOr<Schema> {
    let text = |description: &'static str| {
        ObjectBuilder::new()
            .schema_type(Type::String)
            .description(Some(description))
    };
    RefOr::T(Schema::Object(
        ObjectBuilder::new()
            .schema_type(Type::Object)
            .description(Some(
                "One server-sent event of the stream: `event: pose` with `data:` the JSON of a \
                 PoseResponse, or `event: status` with the JSON of a SessionInfo; each with its \
                 `id:`.",
            ))
            .property(
                "event",
                text("`pose` or `status`").enum_values(Some(["pose", "status"])),
            )
            .property("id", text("The event's number, for Last-Event-ID"))
            .property("data", text("JSON: PoseResponse or SessionInfo"))
            .required("event")
            .required("data")
            .build(),
    ))
}

/// `map.yaml`, the ROS map_server metadata, as a YAML reader sees it.
fn map_yaml() -> RefOr<Schema> {
    let number = || ObjectBuilder::new().schema_type(Type::Number);
    let mut schema = ObjectBuilder::new()
        .schema_type(Type::Object)
        .description(Some("ROS map_server metadata of map.pgm"))
        .property("image", ObjectBuilder::new().schema_type(Type::String))
        .property("resolution", number())
        .property(
            "origin",
            utoipa::openapi::schema::ArrayBuilder::new()
                .items(number())
                .min_items(Some(3))
                .max_items(Some(3)),
        )
        .property("negate", ObjectBuilder::new().schema_type(Type::Integer))
        .property("occupied_thresh", number())
        .property("free_thresh", number());
    for field in [
        "image",
        "resolution",
        "origin",
        "negate",
        "occupied_thresh",
        "free_thresh",
    ] {
        schema = schema.required(field);
    }
    RefOr::T(Schema::Object(schema.build()))
}

#[cfg(test)]
mod tests {
    use serde_json::Value;
    use utoipa::OpenApi;

    use crate::openapi::ApiDoc;

    fn doc() -> Value {
        serde_json::to_value(ApiDoc::openapi()).unwrap()
    }

    fn operations(doc: &Value) -> Vec<(String, String, Value)> {
        let mut out = Vec::new();
        for (path, item) in doc["paths"].as_object().unwrap() {
            for (method, op) in item.as_object().unwrap() {
                if ["get", "post", "put", "delete"].contains(&method.as_str()) {
                    out.push((path.clone(), method.clone(), op.clone()));
                }
            }
        }
        out
    }

    #[test]
    fn every_secured_operation_documents_401_and_healthz_is_open() {
        let doc = doc();
        assert_eq!(
            doc["paths"]["/healthz"]["get"]["security"],
            Value::Array(vec![])
        );
        for (path, method, op) in operations(&doc) {
            if path != "/healthz" {
                assert!(
                    op["responses"]["401"].is_object(),
                    "{method} {path}: no 401"
                );
                assert!(
                    op["security"].is_null(),
                    "{method} {path}: {}",
                    op["security"]
                );
            }
            if op["requestBody"].is_object() {
                assert!(
                    op["responses"]["413"].is_object(),
                    "{method} {path}: no 413"
                );
            }
            for status in ["408", "414", "431"] {
                let r = &op["responses"][status];
                assert!(
                    r.is_object() && r["content"].is_null(),
                    "{method} {path}: {status} {r}"
                );
            }
        }
    }

    #[test]
    fn binary_bodies_are_binary_strings_and_uploads_take_jpeg() {
        let doc = doc();
        for (path, method, op) in operations(&doc) {
            let mut contents = Vec::new();
            if let Some(c) = op["requestBody"]["content"].as_object() {
                contents.extend(c.iter().map(|(k, v)| (k.clone(), v.clone())));
            }
            for response in op["responses"].as_object().unwrap().values() {
                if let Some(c) = response["content"].as_object() {
                    contents.extend(c.iter().map(|(k, v)| (k.clone(), v.clone())));
                }
            }
            for (content_type, content) in contents {
                if content_type.starts_with("image/") {
                    assert_eq!(
                        content["schema"]["type"], "string",
                        "{method} {path} {content_type}"
                    );
                    assert_eq!(
                        content["schema"]["format"], "binary",
                        "{method} {path} {content_type}"
                    );
                }
                if content_type == "text/event-stream" {
                    assert_eq!(content["schema"]["type"], "object", "{method} {path}");
                    assert!(content["schema"]["properties"]["data"].is_object());
                }
            }
        }
        let upload = &doc["paths"]["/v1/sketches"]["post"]["requestBody"]["content"];
        assert!(
            upload["image/png"].is_object() && upload["image/jpeg"].is_object(),
            "{upload}"
        );
    }
}
