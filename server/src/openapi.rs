//! The OpenAPI 3.1 document of the REST API, served at `GET /v1/openapi.json`. Kept next to the
//! router; a test checks that every route of [`crate::rest::router`] is described.

use serde_json::{json, Value};

fn error_response(description: &str) -> Value {
    json!({"description": description, "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Error"}}}})
}

fn id_param() -> Value {
    json!({"name": "id", "in": "path", "required": true, "schema": {"type": "integer", "minimum": 1}, "description": "Job id"})
}

fn query(name: &str, ty: &str, description: &str) -> Value {
    json!({"name": name, "in": "query", "required": false, "schema": {"type": ty}, "description": description})
}

/// The document.
pub fn document() -> Value {
    json!({
        "openapi": "3.1.0",
        "info": {
            "title": "Sable",
            "version": sable_engine::VERSION,
            "description": "Simulation of granular and soft-particle materials as a service: submit a scene, follow its progress, read its samples. The scene format is docs/scene-format.md; the same operations exist over gRPC (sable.v1.Simulations)."
        },
        "paths": {
            "/v1/jobs": {
                "post": {
                    "operationId": "submitJob",
                    "summary": "Validate and queue a scene",
                    "parameters": [{"name": "Idempotency-Key", "in": "header", "required": false, "schema": {"type": "string", "maxLength": 200}, "description": "The same key returns the job created by the first request (200 instead of 201); with another scene it is a 409."}],
                    "requestBody": {"required": true, "content": {"application/json": {"schema": {"oneOf": [
                        {"$ref": "#/components/schemas/Scene"},
                        {"$ref": "#/components/schemas/Submission"}
                    ]}}}},
                    "responses": {
                        "201": {"description": "Queued", "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Job"}}}},
                        "200": {"description": "Already submitted with this Idempotency-Key", "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Job"}}}},
                        "400": error_response("The body is not a JSON object"),
                        "413": error_response("The body is larger than the server's limit"),
                        "422": error_response("The scene or a field breaks a rule; every violation is listed in details"),
                        "409": error_response("Idempotency-Key reused with another scene")
                    }
                },
                "get": {
                    "operationId": "listJobs",
                    "summary": "Jobs, newest first",
                    "parameters": [
                        query("state", "string", "queued, running, succeeded, failed or cancelled"),
                        query("name", "string", "Exact name"),
                        query("method", "string", "Method name, e.g. dem"),
                        query("created_after", "string", "RFC 3339 time (inclusive)"),
                        query("created_before", "string", "RFC 3339 time (exclusive)"),
                        query("page_size", "integer", "1 to 500, default 50"),
                        query("page_token", "string", "next_page_token of the previous page")
                    ],
                    "responses": {
                        "200": {"description": "A page", "content": {"application/json": {"schema": {"type": "object", "properties": {
                            "jobs": {"type": "array", "items": {"$ref": "#/components/schemas/Job"}},
                            "next_page_token": {"type": "string", "description": "Empty on the last page"}
                        }}}}},
                        "400": error_response("A query parameter cannot be read"),
                        "422": error_response("A filter breaks a rule")
                    }
                }
            },
            "/v1/jobs/{id}": {
                "get": {
                    "operationId": "getJob",
                    "summary": "One job",
                    "parameters": [id_param()],
                    "responses": {
                        "200": {"description": "The job", "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Job"}}}},
                        "404": error_response("No such job")
                    }
                }
            },
            "/v1/jobs/{id}:cancel": {
                "post": {
                    "operationId": "cancelJob",
                    "summary": "Cancel a queued or running job (a running one stops within a second)",
                    "parameters": [id_param()],
                    "responses": {
                        "200": {"description": "The job after the request", "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Job"}}}},
                        "404": error_response("No such job"),
                        "409": error_response("The job has already ended")
                    }
                }
            },
            "/v1/jobs/{id}/samples": {
                "get": {
                    "operationId": "getSamples",
                    "summary": "The job's measured time series",
                    "parameters": [
                        id_param(),
                        query("from_step", "integer", "First step (inclusive)"),
                        query("to_step", "integer", "Last step (inclusive)"),
                        query("max_points", "integer", "Keep at most this many samples, evenly spread"),
                        query("format", "string", "json (default) or csv")
                    ],
                    "responses": {
                        "200": {"description": "Samples", "content": {
                            "application/json": {"schema": {"type": "object", "properties": {
                                "job_id": {"type": "integer"},
                                "samples": {"type": "array", "items": {"$ref": "#/components/schemas/Sample"}}
                            }}},
                            "text/csv": {"schema": {"type": "string"}}
                        }},
                        "400": error_response("A parameter cannot be read"),
                        "422": error_response("A parameter breaks a rule"),
                        "404": error_response("No such job")
                    }
                }
            },
            "/v1/jobs/{id}/events": {
                "get": {
                    "operationId": "watchJob",
                    "summary": "Server-Sent Events: state changes and samples, then the end of the stream at the final state",
                    "description": "Each event has id = sequence number and event = state | sample | heartbeat; data is JSON. Resume with after_seq or the Last-Event-ID header.",
                    "parameters": [id_param(), query("after_seq", "integer", "Send events after this sequence number")],
                    "responses": {
                        "200": {"description": "The event stream", "content": {"text/event-stream": {"schema": {"type": "string"}}}},
                        "404": error_response("No such job"),
                        "429": error_response("Too many open event streams")
                    }
                }
            },
            "/v1/openapi.json": {
                "get": {"operationId": "openapi", "summary": "This document", "responses": {"200": {"description": "OpenAPI 3.1", "content": {"application/json": {}}}}}
            },
            "/healthz": {
                "get": {"operationId": "healthz", "summary": "Liveness: the database answers", "responses": {
                    "200": {"description": "Healthy"}, "503": {"description": "The database does not answer"}
                }}
            },
            "/metrics": {
                "get": {"operationId": "metrics", "summary": "Prometheus metrics: jobs by state, queue depth, job durations, worker use", "responses": {
                    "200": {"description": "Prometheus text format", "content": {"text/plain": {"schema": {"type": "string"}}}}
                }}
            }
        },
        "components": {"schemas": {
            "Scene": {"type": "object", "description": "A scene (docs/scene-format.md): dimension, method, materials, particles, container, gravity, stop, sampling, seed.", "required": ["dimension", "materials", "particles", "container", "stop"]},
            "Submission": {"type": "object", "required": ["scene"], "additionalProperties": false, "properties": {
                "scene": {"$ref": "#/components/schemas/Scene"},
                "name": {"type": "string", "maxLength": 200},
                "priority": {"type": "integer", "minimum": -1000, "maximum": 1000, "description": "Higher runs first; FIFO within a priority"},
                "max_attempts": {"type": "integer", "minimum": 1, "maximum": 20, "default": 3}
            }},
            "Job": {"type": "object", "properties": {
                "id": {"type": "integer"},
                "name": {"type": "string"},
                "state": {"type": "string", "enum": ["queued", "running", "succeeded", "failed", "cancelled"]},
                "method": {"type": "string"},
                "method_reason": {"type": "string"},
                "priority": {"type": "integer"},
                "created_at": {"type": "string", "format": "date-time"},
                "started_at": {"type": ["string", "null"], "format": "date-time"},
                "finished_at": {"type": ["string", "null"], "format": "date-time"},
                "attempts": {"type": "integer"},
                "max_attempts": {"type": "integer"},
                "progress": {"type": "number", "minimum": 0, "maximum": 1},
                "error": {"type": ["object", "null"], "properties": {"code": {"type": "string"}, "message": {"type": "string"}}},
                "scene": {"$ref": "#/components/schemas/Scene"},
                "scene_hash": {"type": "string"},
                "engine_version": {"type": "string"},
                "seed": {"type": "integer"},
                "steps": {"type": "integer"},
                "wall_seconds": {"type": "number"},
                "sample_count": {"type": "integer"},
                "cancel_requested": {"type": "boolean"}
            }},
            "Sample": {"type": "object", "description": "One measurement (engine field names)", "properties": {
                "step": {"type": "integer"}, "time": {"type": "number", "description": "s"},
                "phi": {"type": "number"}, "z": {"type": "number"}, "z_no_rattlers": {"type": "number"},
                "mu": {"type": "number"}, "p": {"type": "number", "description": "Pa"}, "q": {"type": "number", "description": "Pa"},
                "stress": {"type": "object", "description": "Pa; xx, yy, xy (and zz, xz, yz in 3D)"},
                "inertial_number": {"type": ["number", "null"]},
                "kinetic_energy": {"type": "number", "description": "J"}, "elastic_energy": {"type": "number", "description": "J"},
                "walls": {"type": "array", "items": {"type": "object"}}
            }},
            "Error": {"type": "object", "required": ["code", "message", "details"], "properties": {
                "code": {"type": "string", "enum": ["malformed", "invalid_argument", "too_large", "resource_exhausted", "not_found", "conflict", "internal"]},
                "message": {"type": "string"},
                "details": {"type": "array", "items": {"type": "object", "properties": {"field": {"type": "string"}, "rule": {"type": "string"}}}}
            }}
        }}
    })
}
