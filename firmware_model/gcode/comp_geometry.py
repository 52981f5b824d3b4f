"""The plane geometry of cutter radius compensation
(:mod:`k37.firmware_model.gcode.cutter_comp`): unit vectors, where lines and circles cross,
how far an arc turns, and rs274's own construction of an arc-to-line inside corner."""

from __future__ import annotations

import math

__all__ = ["arc_line_corner", "circles", "line_circle", "sweep", "unit"]


def unit(dx: float, dy: float) -> tuple[float, float]:
    length = math.hypot(dx, dy)
    return dx / length, dy / length


def line_circle(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float],
                 radius: float) -> list[tuple[float, float]]:
    """Where the line through ``a`` and ``b`` crosses the circle."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    fx, fy = a[0] - c[0], a[1] - c[1]
    qa, qb, qc = dx * dx + dy * dy, 2 * (fx * dx + fy * dy), fx * fx + fy * fy - radius ** 2
    disc = qb * qb - 4 * qa * qc
    if qa == 0 or disc < 0:
        return []
    return [(a[0] + t * dx, a[1] + t * dy)
            for t in ((-qb - math.sqrt(disc)) / (2 * qa), (-qb + math.sqrt(disc)) / (2 * qa))]


def circles(c0: tuple[float, float], r0: float, c1: tuple[float, float],
             r1: float) -> list[tuple[float, float]]:
    """Where two circles cross."""
    d = math.dist(c0, c1)
    if d == 0 or d > r0 + r1 or d < abs(r0 - r1):
        return []
    a = (r0 * r0 - r1 * r1 + d * d) / (2 * d)
    h = math.sqrt(max(0.0, r0 * r0 - a * a))
    ux, uy = (c1[0] - c0[0]) / d, (c1[1] - c0[1]) / d
    mx, my = c0[0] + a * ux, c0[1] + a * uy
    return [(mx - h * uy, my + h * ux), (mx + h * uy, my - h * ux)]


def sweep(start: tuple[float, float], centre: tuple[float, float], cw: bool,
           end: tuple[float, float]) -> float:
    """How far an arc from ``start`` to ``end`` turns (radians, more than 0, up to a full
    turn), as rs274's ``find_turn``."""
    turn = (math.atan2(end[1] - centre[1], end[0] - centre[0])
            - math.atan2(start[1] - centre[1], start[0] - centre[0]))
    return (-turn if cw else turn) % (2 * math.pi) or 2 * math.pi


def arc_line_corner(centre: tuple[float, float], radius: float, ccw: bool, inside: bool,
                    corner: tuple[float, float], direction: float,
                    r: float) -> tuple[float, float] | None:
    """Where a held arc (compensated: ``centre``, ``radius``; ``ccw``; the tool ``inside``
    it) ends before a line going ``direction`` (radians) from the programmed ``corner``, for
    a cutter of radius ``r``: rs274's construction (which takes the corner to be a radius
    off the compensated circle, as it is unless the arc is the entry move); None where the
    tool cannot fit."""
    theta = direction + (math.pi / 2 if ccw else -math.pi / 2)
    phi = math.atan2(centre[1] - corner[1], centre[0] - corner[0])
    d = (radius + r if inside else radius - r) * math.cos(theta - phi)
    cos_angle = (d - r if inside else d + r) / radius
    if abs(cos_angle) > 1.0:
        return None
    turn = math.acos(cos_angle) * (1 if ccw != inside else -1)
    angle = turn + theta + math.pi
    return centre[0] + radius * math.cos(angle), centre[1] + radius * math.sin(angle)
