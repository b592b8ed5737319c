"""The camera tool: keyframed camera paths written as USD time samples.

Each path gives a camera-to-world matrix per frame (look-at, Y up): orbit, pan, dolly and
fly-through along a polyline.
"""
from __future__ import annotations

import numpy as np


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Camera-to-world (4, 4, column-vector) looking from ``eye`` at ``target`` (−z forward)."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = r, u, -f, eye
    return M


def _frames(frames):
    lo, hi = frames
    return np.arange(lo, hi + 1), max(hi - lo, 1)


def orbit(centre, radius: float, height: float, start_deg: float, end_deg: float, frames, target_height=None):
    """Circle around ``centre`` (x, y, z) from ``start_deg`` to ``end_deg`` at ``height``."""
    fs, n = _frames(frames)
    c = np.asarray(centre, float)
    th = target_height if target_height is not None else c[1]
    out = {}
    for f in fs:
        a = np.radians(start_deg + (end_deg - start_deg) * (f - fs[0]) / n)
        eye = c + np.array([radius * np.sin(a), height, radius * np.cos(a)])
        out[int(f)] = look_at(eye, [c[0], th, c[2]])
    return out


def pan(eye, yaw_start: float, yaw_end: float, pitch: float, frames):
    """Turn in place from ``yaw_start`` to ``yaw_end`` degrees (0 looks down −z), tilted by ``pitch``."""
    fs, n = _frames(frames)
    eye = np.asarray(eye, float)
    out = {}
    for f in fs:
        y = np.radians(yaw_start + (yaw_end - yaw_start) * (f - fs[0]) / n)
        p = np.radians(pitch)
        d = np.array([-np.sin(y) * np.cos(p), np.sin(p), -np.cos(y) * np.cos(p)])
        out[int(f)] = look_at(eye, eye + d)
    return out


def dolly(start, end, target, frames):
    """Move the eye from ``start`` to ``end`` while looking at ``target``."""
    fs, n = _frames(frames)
    a, b = np.asarray(start, float), np.asarray(end, float)
    return {int(f): look_at(a + (b - a) * (f - fs[0]) / n, target) for f in fs}


def fly_through(points, frames, look_ahead: float = 0.05):
    """Follow the polyline ``points`` at constant speed, looking ``look_ahead`` of the path ahead."""
    pts = np.asarray(points, float)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)]) / seg.sum()
    fs, n = _frames(frames)
    end_dir = pts[-1] - pts[-2]

    def at(u):
        if u > 1.0:  # past the end: keep going straight
            return pts[-1] + end_dir / np.linalg.norm(end_dir) * (u - 1.0) * seg.sum()
        return np.array([np.interp(u, s, pts[:, k]) for k in range(3)])

    return {int(f): look_at(at((f - fs[0]) / n), at((f - fs[0]) / n + look_ahead)) for f in fs}


def from_dict(d: dict, frames) -> dict[int, np.ndarray]:
    kind = d.get("move", "orbit")
    if kind == "orbit":
        return orbit(d["centre"], d["radius"], d["height"], d["start_deg"], d["end_deg"], frames, d.get("target_height"))
    if kind == "pan":
        return pan(d["eye"], d["yaw_start"], d["yaw_end"], d.get("pitch", 0.0), frames)
    if kind == "dolly":
        return dolly(d["start"], d["end"], d["target"], frames)
    if kind == "fly_through":
        return fly_through(d["points"], frames, d.get("look_ahead", 0.05))
    raise ValueError(f"camera move {kind!r} is not valid; valid moves are orbit, pan, dolly, fly_through")
