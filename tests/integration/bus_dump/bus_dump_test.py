#!/usr/bin/env python3
"""Checks fieldline-bus-dump's JSON lines for the fixture log of write_fixture.cpp.

usage: bus_dump_test.py DUMP.jsonl [--image-data] [--live]
Every line must parse as JSON; every message must equal the values write_fixture.cpp wrote.
--live: the dump is of a bus the log was played onto: a receive time instead of the event.
"""
import json
import math
import sys

BASE = 1_700_000_000_000_000


def header(seq, robot_id=2):
    return {"utime": BASE + seq * 1000, "utime_published": BASE + seq * 1000 + 250,
            "seq": seq, "robot_id": robot_id, "publisher_id": 0x5eed00 + seq}


def fnv1a64(data):
    h = 0xcbf29ce484222325
    for b in data:
        h ^= b
        h = (h * 0x100000001b3) % (1 << 64)
    return f"{h:016x}"


IMAGE_BYTES = [0, 1, 2, 3, 250, 251, 252, 253]
ODOMETRY = {"wheel_count": 4, "ticks": [100, -200, 2147483647, -5], "controller_utime": 9876543210,
            "dx": 0.015625, "dy": -0.0078125, "dphi": 0.001, "vx": 0.78125, "vy": -0.390625,
            "omega": 0.05, "status": 60, "wheel_current": [1.25, -0.5, 0, 0.75],
            "gyro_dphi": 0.0009765625}

EXPECTED = [
    ("CAMERA_IMAGE", {"header": header(0), "width": 4, "height": 2, "stride": 4, "format": 3,
                      "source": 5, "frame_number": 77, "exposure_us": 5000, "size": 8}),
    ("VISION_LINES", {"header": header(1), "num_points": 3, "u": [10.5, 11.5, 12.5],
                      "v": [20.25, 21.25, 22.25], "x": [1, 1.5, 2], "y": [-0.5, 0, 0.5],
                      "num_sequences": 1, "sequence_start": [0], "sequence_end": [3],
                      "image_width": 640, "image_height": 480, "cells_touched": 1234,
                      "touched_fraction": 0.125, "overlap_fraction": 0.75,
                      "initial_searches": 2, "processing_us": 4321}),
    ("VISION_BALL", {"header": header(2), "visible": True, "u": 100.5, "v": 200.5, "x": 3.25,
                     "y": -1.75, "sigma_radial": 0.125, "sigma_tangential": 0.0625,
                     "cells": 42, "confidence": 0.875}),
    ("VISION_OBSTACLES", {"header": header(3), "count": 2, "bearing": [0.5, -1.25],
                          "distance": [2.5, 4], "angular_width": [0.25, 0.125],
                          "width": [0.5, 0.5], "x": [2, 1], "y": [1, -3.5]}),
    ("FIELD_FEATURES", {"header": header(4), "num_features": 2, "kind": [1, 4],
                        "feature_x": [1.5, 3], "feature_y": [0.25, -2],
                        "feature_phi": [0.5, 1.5], "quality": [0.75, 0.5],
                        "num_hypotheses": 3, "hypothesis_feature": [0, 0, 1],
                        "pose_x": [-1.5, 1.5, 4], "pose_y": [-0.25, 0.25, 2],
                        "pose_phi": [0, 3, -1], "sigma_xy": [0.25, 0.25, 0.5],
                        "sigma_phi": [0.125, 0.125, 0.25]}),
    ("ODOMETRY", dict(header=header(5), **ODOMETRY)),
    ("MOTION_COMMAND", {"header": header(6), "vx": 0.5, "vy": -0.25, "omega": 0.1,
                        "deadline_utime": BASE + 206000, "source": 1}),
    ("ROBOT_STATE", {"header": header(7), "x": 1.25, "y": -2.5, "phi": 3.141592653589793,
                     "vx": 0.5, "vy": 0.25, "omega": -0.125,
                     "covariance": [0.01, 0, 0, 0, 0.05, 0, 0, 0, 0.09], "status": 2,
                     "since_vision_us": 33000, "twin_ambiguous": True}),
    ("BALL_STATE", {"header": header(8), "valid": False, "x": 4.5, "y": 1.5, "vx": -1,
                    "vy": 0, "covariance": [0.04, 0.001, 0.001, 0.09],
                    "last_seen_utime": BASE + 7000}),
    ("TEAM_STATE", {"header": header(9), "num_robots": 2, "present": [True, False],
                    "robot_x": [1, 0], "robot_y": [2, 0], "robot_phi": [0.5, 0],
                    "robot_sigma_xy": [0.25, 0], "robot_age_us": [12000, 0],
                    "ball_valid": [True, False], "ball_x": [3, 0], "ball_y": [-1, 0],
                    "ball_age_us": [40000, 0], "clock_offset_us": [-1500, 0],
                    "round_trip_us": [800, 0], "packets_received": [500, 0],
                    "packets_rejected": [3, 0], "robot_twin_ambiguous": [True, False],
                    "team_ball_valid": True, "team_ball_x": 3,
                    "team_ball_y": -1, "team_ball_vx": 0.5, "team_ball_vy": 0.25,
                    "team_ball_covariance": [0.01, 0, 0, 0.02]}),
    ("SERVICE_STATUS", {"header": header(10),
                        # the byte 0xff is not UTF-8: it comes out as U+FFFD
                        "process": "dump \"test\" \\ tab\t \u00b5s \ufffd",
                        "pid": 4242, "uptime_us": 60000000, "period_us": 1000000, "state": 1,
                        "num_channels": 1, "channel": ["ODOMETRY"], "direction": [0],
                        "messages_total": [3000], "rate_hz": [50], "drops_total": [1],
                        "rejected_total": [2], "latency_p50_ms": [1.5],
                        "latency_p95_ms": [2.5], "latency_max_ms": [4],
                        "processing_p50_ms": 0.25, "processing_p95_ms": 0.5,
                        "processing_max_ms": 1, "num_errors": 1, "error_kind": ["decode"],
                        "error_count": [2], "last_error": "undecodable message of 3 bytes",
                        "last_error_utime": BASE + 5000, "num_metrics": 1,
                        "metric_name": ["fps"], "metric_value": [30],
                        "state_reason": "ODOMETRY silent 2.1 s"}),
    ("SIM_WORLD", {"header": header(11, robot_id=0), "field": "msl", "scenario": "kidnap",
                   "num_robots": 1, "robot_id": [2], "robot_x": [1], "robot_y": [-1],
                   "robot_phi": [0.5], "robot_vx": [0.25], "robot_vy": [0],
                   "robot_omega": [0.125], "robot_kidnaps": [1], "robot_radius": 0.25,
                   "num_opponents": 1, "opponent_x": [5], "opponent_y": [2],
                   "opponent_phi": [3], "opponent_radius": [0.25], "ball_x": 0.5,
                   "ball_y": 0.75, "ball_vx": 0, "ball_vy": -0.5, "ball_radius": 0.11}),
    # events 12 (garbage) and 13 (NaN) are rejected; 14 is good again
    ("ODOMETRY", dict(header=header(14), **ODOMETRY)),
]
EVENT_NUMBERS = list(range(12)) + [14]


def same(a, b, path):
    """Exact structure and types (bool is not a number); floats equal to float32 precision."""
    if isinstance(b, bool) or isinstance(a, bool):
        assert a is b, f"{path}: {a!r} != {b!r}"
    elif isinstance(b, (int, float)) and not isinstance(b, bool):
        assert isinstance(a, (int, float)), f"{path}: {a!r} is not a number"
        assert math.isclose(a, b, rel_tol=1e-7, abs_tol=0), f"{path}: {a!r} != {b!r}"
        if isinstance(b, int) and isinstance(a, int):
            assert a == b, f"{path}: {a} != {b}"
    elif isinstance(b, list):
        assert isinstance(a, list) and len(a) == len(b), f"{path}: {a!r} != {b!r}"
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    elif isinstance(b, dict):
        assert isinstance(a, dict), f"{path}: {a!r} is not an object"
        assert list(a.keys()) == list(b.keys()), f"{path}: keys {list(a)} != {list(b)}"
        for k in b:
            same(a[k], b[k], f"{path}.{k}")
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


def main():
    path = sys.argv[1]
    image_data = "--image-data" in sys.argv[2:]
    live = "--live" in sys.argv[2:]
    with open(path, encoding="utf-8") as f:
        lines = [json.loads(line) for line in f]
    if live:
        # Probes (seq 1000) that told the test the dump was listening.
        lines = [m for m in lines if m["message"]["header"]["seq"] != 1000]
    assert len(lines) == len(EXPECTED), f"{len(lines)} messages, expected {len(EXPECTED)}"
    for line, number, (channel, message) in zip(lines, EVENT_NUMBERS, EXPECTED):
        message = dict(message)
        if channel == "CAMERA_IMAGE":
            if image_data:
                message["data"] = IMAGE_BYTES
            else:
                message["data_fnv1a64"] = fnv1a64(IMAGE_BYTES)
        utime = message["header"]["utime"]
        if live:
            # The receive time is this machine's clock: only its presence and order can be checked.
            receive = line.get("receive_utime")
            assert isinstance(receive, int) and receive > utime, f"{channel}: {receive!r}"
            expected = {"channel": channel, "receive_utime": receive, "message": message}
        else:
            expected = {"channel": channel, "event": number, "log_utime": utime + 350,
                        "message": message}
        same(line, expected, channel)
    print(f"{len(lines)} messages as expected")


if __name__ == "__main__":
    main()
