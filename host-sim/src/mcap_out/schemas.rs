//! JSON schemas of the Foxglove well-known message types this file writes
//! (`foxglove.LaserScan`, `foxglove.PoseInFrame`, `foxglove.FrameTransform`,
//! `foxglove.SceneUpdate` with line primitives), as Foxglove's own `jsonschema` definitions
//! give them (encoding `jsonschema`, messages encoded `json`). Foxglove Studio recognises the
//! types by these schema names and draws them in its 3D panel.

use serde_json::{json, Value};

fn time(description: &str) -> Value {
    json!({
        "type": "object", "title": "time", "description": description,
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}
        }
    })
}

fn vector3(description: &str) -> Value {
    json!({
        "title": "foxglove.Vector3", "description": description, "type": "object",
        "properties": {
            "x": {"type": "number", "description": "x coordinate length"},
            "y": {"type": "number", "description": "y coordinate length"},
            "z": {"type": "number", "description": "z coordinate length"}
        }
    })
}

fn quaternion(description: &str) -> Value {
    json!({
        "title": "foxglove.Quaternion", "description": description, "type": "object",
        "properties": {
            "x": {"type": "number", "description": "x value"},
            "y": {"type": "number", "description": "y value"},
            "z": {"type": "number", "description": "z value"},
            "w": {"type": "number", "description": "w value"}
        }
    })
}

fn pose(description: &str) -> Value {
    json!({
        "title": "foxglove.Pose", "description": description, "type": "object",
        "properties": {
            "position": vector3("Point denoting position in 3D space"),
            "orientation": quaternion("Quaternion denoting orientation in 3D space")
        }
    })
}

fn color(description: &str) -> Value {
    json!({
        "title": "foxglove.Color", "description": description, "type": "object",
        "properties": {
            "r": {"type": "number", "description": "Red value between 0 and 1"},
            "g": {"type": "number", "description": "Green value between 0 and 1"},
            "b": {"type": "number", "description": "Blue value between 0 and 1"},
            "a": {"type": "number", "description": "Alpha value between 0 and 1"}
        }
    })
}

/// `foxglove.LaserScan`.
pub fn laser_scan() -> Value {
    json!({
        "title": "foxglove.LaserScan",
        "description": "A single scan from a planar laser range-finder",
        "type": "object",
        "properties": {
            "timestamp": time("Timestamp of scan"),
            "frame_id": {"type": "string", "description": "Frame of reference"},
            "pose": pose("Origin of scan relative to frame of reference"),
            "start_angle": {"type": "number", "description": "Bearing of first point, in radians"},
            "end_angle": {"type": "number", "description": "Bearing of last point, in radians"},
            "ranges": {"type": "array", "items": {"type": "number"},
                "description": "Distance of detections from origin; assumed to be at equally-spaced angles between `start_angle` and `end_angle`"},
            "intensities": {"type": "array", "items": {"type": "number"},
                "description": "Intensity of detections"}
        }
    })
}

/// `foxglove.PoseInFrame`.
pub fn pose_in_frame() -> Value {
    json!({
        "title": "foxglove.PoseInFrame",
        "description": "A timestamped pose for an object or reference frame in 3D space",
        "type": "object",
        "properties": {
            "timestamp": time("Timestamp of pose"),
            "frame_id": {"type": "string", "description": "Frame of reference for pose position and orientation"},
            "pose": pose("Pose in 3D space")
        }
    })
}

/// `foxglove.FrameTransform`.
pub fn frame_transform() -> Value {
    json!({
        "title": "foxglove.FrameTransform",
        "description": "A transform between two reference frames in 3D space",
        "type": "object",
        "properties": {
            "timestamp": time("Timestamp of transform"),
            "parent_frame_id": {"type": "string", "description": "Name of the parent frame"},
            "child_frame_id": {"type": "string", "description": "Name of the child frame"},
            "translation": vector3("Translation component of the transform"),
            "rotation": quaternion("Rotation component of the transform")
        }
    })
}

/// `foxglove.SceneUpdate` (entities with line primitives; deletions).
pub fn scene_update() -> Value {
    let line = json!({
        "title": "foxglove.LinePrimitive",
        "description": "A primitive representing a series of points connected by lines",
        "type": "object",
        "properties": {
            "type": {"title": "foxglove.LineType", "description": "Drawing primitive to use for lines",
                "oneOf": [
                    {"title": "LINE_STRIP", "const": 0, "description": "Connected line segments: 0-1, 1-2, ..., (n-1)-n"},
                    {"title": "LINE_LOOP", "const": 1, "description": "Closed polygon: 0-1, 1-2, ..., (n-1)-n, n-0"},
                    {"title": "LINE_LIST", "const": 2, "description": "Individual line segments: 0-1, 2-3, 4-5, ..."}
                ]},
            "pose": pose("Origin of lines relative to reference frame"),
            "thickness": {"type": "number", "minimum": 0, "description": "Line thickness"},
            "scale_invariant": {"type": "boolean", "description": "Indicates whether `thickness` is a fixed size in screen pixels (true), or specified in world coordinates and scales with distance from the camera (false)"},
            "points": {"type": "array", "items": {
                "title": "foxglove.Point3", "description": "A point representing a position in 3D space", "type": "object",
                "properties": {
                    "x": {"type": "number", "description": "x coordinate position"},
                    "y": {"type": "number", "description": "y coordinate position"},
                    "z": {"type": "number", "description": "z coordinate position"}
                }}, "description": "Points along the line"},
            "color": color("Solid color to use for the whole line. One of `color` or `colors` must be provided."),
            "colors": {"type": "array", "items": color("A color in RGBA format"), "description": "Per-point colors (if specified, must have the same length as `points`). One of `color` or `colors` must be provided."},
            "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}, "description": "Indices into the `points` and `colors` attribute arrays, which can be used to avoid duplicating attribute data."}
        }
    });
    json!({
        "title": "foxglove.SceneUpdate",
        "description": "An update to the entities displayed in a 3D scene",
        "type": "object",
        "properties": {
            "deletions": {"type": "array", "items": {
                "title": "foxglove.SceneEntityDeletion", "type": "object",
                "description": "Command to remove previously published entities",
                "properties": {
                    "timestamp": time("Timestamp of the deletion. Only matching entities earlier than this timestamp will be deleted."),
                    "type": {"title": "foxglove.SceneEntityDeletionType", "oneOf": [
                        {"title": "MATCHING_ID", "const": 0}, {"title": "ALL", "const": 1}]},
                    "id": {"type": "string"}
                }}, "description": "Scene entities to delete"},
            "entities": {"type": "array", "items": {
                "title": "foxglove.SceneEntity", "type": "object",
                "description": "A visual element in a 3D scene. An entity may be composed of multiple primitives which all share the same frame of reference.",
                "properties": {
                    "timestamp": time("Timestamp of the entity"),
                    "frame_id": {"type": "string", "description": "Frame of reference"},
                    "id": {"type": "string", "description": "Identifier for the entity. A entity will replace any prior entity on the same topic with the same `id`."},
                    "lifetime": {"type": "object", "title": "duration", "properties": {
                        "sec": {"type": "integer"}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}},
                        "description": "Length of time (relative to `timestamp`) after which the entity should be automatically removed. Zero value indicates the entity should remain visible until it is replaced or deleted."},
                    "frame_locked": {"type": "boolean", "description": "Whether the entity should keep its location in the fixed frame (false) or follow the frame specified in `frame_id` as it moves relative to the fixed frame (true)"},
                    "metadata": {"type": "array", "items": {"title": "foxglove.KeyValuePair", "type": "object",
                        "properties": {"key": {"type": "string"}, "value": {"type": "string"}}}},
                    "lines": {"type": "array", "items": line, "description": "Line primitives"}
                }}, "description": "Scene entities to add or replace"}
        }
    })
}
