"""Closed-form planar kinematics used as independent references in tests.

Conventions (both mechanisms): planar x–y, angles measured from the ground
x axis, counter-clockwise positive, in rad; lengths in m; time derivatives
follow from the crank angle θ(t) with given rate θ̇ (rad/s) and angular
acceleration θ̈ (rad/s²). All functions broadcast over numpy arrays.

Slider-crank: crank pivot at the origin, crank pin A = r(cos θ, sin θ); the
slider pin B moves on the line y = e (offset e, signed); the rod from A to B
has length l and angle φ: B = A + l(cos φ, sin φ) = (x, e).

Four-bar: ground pivots O2 = (0, 0) (crank a) and O4 = (d, 0) (rocker c);
crank pin A = a(cos θ2, sin θ2); coupler b from A to B at angle θ3;
rocker pin B = (d + c cos θ4, c sin θ4). Loop: a e2 + b e3 − c e4 − d x̂ = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SliderCrankState:
    """Slider position x (m), rod angle phi (rad) and their time derivatives."""

    x: np.ndarray
    x_d: np.ndarray
    x_dd: np.ndarray
    phi: np.ndarray
    phi_d: np.ndarray
    phi_dd: np.ndarray


def slider_crank(theta, theta_d, theta_dd, r, l, e=0.0, branch=1):
    """Position, velocity and acceleration of an (offset) slider-crank.

    Parameters
    ----------
    theta, theta_d, theta_dd : float or ndarray
        Crank angle (rad), rate (rad/s), angular acceleration (rad/s²).
    r, l : float
        Crank and connecting-rod lengths (m), ``l > r + |e|`` for a full turn.
    e : float
        Slider-line offset (m): the slider moves on y = e.
    branch : {+1, -1}
        +1: slider to the right of the crank pin (cos φ > 0); -1: to the left.

    Returns
    -------
    SliderCrankState
        From r sin θ + l sin φ = e:  sin φ = (e − r sin θ)/l,
        x = r cos θ + l cos φ,
        φ̇ = −r cos θ θ̇ /(l cos φ),
        φ̈ = [r (sin θ θ̇² − cos θ θ̈) + l sin φ φ̇²]/(l cos φ),
        ẋ = −r sin θ θ̇ − l sin φ φ̇,
        ẍ = −r (sin θ θ̈ + cos θ θ̇²) − l (sin φ φ̈ + cos φ φ̇²).
    """
    th, thd, thdd = (np.asarray(v, dtype=float) for v in (theta, theta_d, theta_dd))
    s = (e - r * np.sin(th)) / l
    if np.any(np.abs(s) > 1.0):
        raise ValueError("slider-crank cannot assemble: |e - r sin(theta)| > l")
    phi = np.arcsin(s) if branch > 0 else np.pi - np.arcsin(s)
    c, sp = np.cos(phi), np.sin(phi)
    x = r * np.cos(th) + l * c
    phi_d = -r * np.cos(th) * thd / (l * c)
    phi_dd = (r * (np.sin(th) * thd**2 - np.cos(th) * thdd) + l * sp * phi_d**2) / (l * c)
    x_d = -r * np.sin(th) * thd - l * sp * phi_d
    x_dd = -r * (np.sin(th) * thdd + np.cos(th) * thd**2) - l * (sp * phi_dd + c * phi_d**2)
    return SliderCrankState(x, x_d, x_dd, phi, phi_d, phi_dd)


def slider_crank_residual(theta, state: SliderCrankState, r, l, e=0.0):
    """Loop residual (2, ...) of r e(θ) + l e(φ) − (x, e); zero when closed."""
    th = np.asarray(theta, dtype=float)
    return np.stack([r * np.cos(th) + l * np.cos(state.phi) - state.x,
                     r * np.sin(th) + l * np.sin(state.phi) - e])


@dataclass(frozen=True)
class FourBarState:
    """Coupler angle theta3 and rocker angle theta4 (rad) with their derivatives."""

    theta3: np.ndarray
    theta3_d: np.ndarray
    theta3_dd: np.ndarray
    theta4: np.ndarray
    theta4_d: np.ndarray
    theta4_dd: np.ndarray


def is_grashof(a, b, c, d) -> bool:
    """Grashof condition s + l <= p + q (some link can turn fully)."""
    s = sorted((a, b, c, d))
    return s[0] + s[3] <= s[1] + s[2]


def four_bar(theta2, theta2_d, theta2_dd, a, b, c, d, branch="open"):
    """Coupler and rocker angles, velocities and accelerations of a four-bar.

    Parameters
    ----------
    theta2, theta2_d, theta2_dd : float or ndarray
        Crank angle (rad), rate (rad/s), angular acceleration (rad/s²).
    a, b, c, d : float
        Crank, coupler, rocker and ground lengths (m).
    branch : {"open", "crossed"}
        "open": B lies to the left of the directed line from A to O4
        ((O4 − A) × (B − A) > 0), the uncrossed drawing with the coupler and
        rocker above the ground line when the crank points up; "crossed": to
        the right.

    Returns
    -------
    FourBarState
        With D = O4 − A = (d − a cos θ2, −a sin θ2), f = |D|, δ = atan2(D):
        θ3 = δ ± acos((b² + f² − c²)/(2 b f)), B = A + b e3,
        θ4 = atan2(B_y, B_x − d). Projecting the differentiated loop on e4
        and e3 (with e_i⊥·e_j = sin(θj − θi), e_i·e_j = cos(θi − θj)):
        θ̇3 = −a θ̇2 sin(θ4 − θ2) / (b sin(θ4 − θ3)),
        θ̇4 =  a θ̇2 sin(θ3 − θ2) / (c sin(θ3 − θ4)),
        θ̈3 = [−a θ̈2 sin(θ4 − θ2) + a θ̇2² cos(θ2 − θ4) + b θ̇3² cos(θ3 − θ4)
               − c θ̇4²] / (b sin(θ4 − θ3)),
        θ̈4 = [a θ̈2 sin(θ3 − θ2) − a θ̇2² cos(θ2 − θ3) − b θ̇3²
               + c θ̇4² cos(θ4 − θ3)] / (c sin(θ3 − θ4)).
        Singular (sin(θ4 − θ3) = 0) only at the coupler–rocker toggle.
    """
    if branch not in ("open", "crossed"):
        raise ValueError(f"branch: expected 'open' or 'crossed', got {branch!r}")
    t2, w2, al2 = (np.asarray(v, dtype=float) for v in (theta2, theta2_d, theta2_dd))
    ax, ay = a * np.cos(t2), a * np.sin(t2)
    dx, dy = d - ax, -ay
    f = np.hypot(dx, dy)
    cos_alpha = (b**2 + f**2 - c**2) / (2 * b * f)
    if np.any(np.abs(cos_alpha) > 1.0):
        raise ValueError("four-bar cannot assemble at some crank angle (not Grashof crank)")
    sign = 1.0 if branch == "open" else -1.0
    t3 = np.arctan2(dy, dx) + sign * np.arccos(cos_alpha)
    bx, by = ax + b * np.cos(t3), ay + b * np.sin(t3)
    t4 = np.arctan2(by, bx - d)
    w3 = -a * w2 * np.sin(t4 - t2) / (b * np.sin(t4 - t3))
    w4 = a * w2 * np.sin(t3 - t2) / (c * np.sin(t3 - t4))
    al3 = (-a * al2 * np.sin(t4 - t2) + a * w2**2 * np.cos(t2 - t4)
           + b * w3**2 * np.cos(t3 - t4) - c * w4**2) / (b * np.sin(t4 - t3))
    al4 = (a * al2 * np.sin(t3 - t2) - a * w2**2 * np.cos(t2 - t3) - b * w3**2
           + c * w4**2 * np.cos(t4 - t3)) / (c * np.sin(t3 - t4))
    return FourBarState(t3, w3, al3, t4, w4, al4)


def four_bar_residual(theta2, state: FourBarState, a, b, c, d):
    """Loop residual (2, ...) of a e2 + b e3 − c e4 − d x̂; zero when closed."""
    t2 = np.asarray(theta2, dtype=float)
    return np.stack([
        a * np.cos(t2) + b * np.cos(state.theta3) - c * np.cos(state.theta4) - d,
        a * np.sin(t2) + b * np.sin(state.theta3) - c * np.sin(state.theta4)])
