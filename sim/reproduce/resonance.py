"""The profile-error paper's feed drive as two masses: its Table 1 axes on the two-mass drive's
reference model, the natural frequencies they ring at, and the JK map's omega-curves (eq. (4)).

The paper's eq. (1) is the free mode of motor side and table joined by the screw's stiffness
(printed as omega where omega^2 is meant); without the screw's mass it is
omega^2 = Ks (1/M + 1/M') = Ks / M_eq, M' = J / R^2. Its eq. (2) prints J / Ja where Table 1's
numbers need Ja / J (Ja = J + R^2 M, the whole inertia at the motor): read so, eq. (2) is that
free mode, eq. (3) (omega^2 = Ks / M) the mode with the motor held, and Table 1's ratio
eq. (3) / eq. (2) = sqrt(M' / (M + M')). Eq. (4), K = omega^2 M J / Ja, is eq. (2) so read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from k37.sim.machine.plant_model import FRAC_BITS, PlantParams
from k37.sim.machine.two_mass_model import TwoMassDriveModel, TwoMassParams
from k37.sim.reproduce.markdown import Section

__all__ = ["TABLE1", "TABLE8_JA", "JkStudy", "Table1Axis", "add_rows", "jk_curve", "plot_jk",
           "ring_hz", "table1_drive"]


@dataclass(frozen=True)
class Table1Axis:
    """One row of Table 1: M and M' (kg), omega by eq. (2) and eq. (3), and their ratio."""

    m: float
    m_prime: float
    eq2: float
    eq3: float
    ratio: float


#: Table 1 (omega read as Hz: the paper gives no unit; the ratio does not depend on it).
TABLE1 = {"x": Table1Axis(241, 3476, 206.3, 199.6, 0.97),
          "y": Table1Axis(676, 5829, 132.9, 125.8, 0.95),
          "z": Table1Axis(1061, 5998, 105.5, 98.3, 0.93)}
#: Table 8's whole inertia at the motor Ja (N m s^2, i.e. kg m^2), which with Table 1's
#: masses gives each axis's lead: R^2 = Ja / (M + M').
TABLE8_JA = {"x": 0.0057, "y": 0.0056, "z": 0.0048}
#: The velocity loop that holds the motor: Kt Vg / J = 2e5/s against omega about 1e3/s.
HELD_RATE = 2e5


def table1_drive(axis: str, *, held: bool = False, ks_scale: float = 1.0,
                 j_scale: float = 1.0) -> TwoMassParams:
    """Axis ``axis`` of Table 1 as a two-mass drive: Ks from its eq. (3) frequency and M (times
    ``ks_scale``), J = M' R^2 (times ``j_scale``), the lead from Table 8's Ja; the velocity
    loop ``held`` (stiff) or weak (1/s: the motor's side practically free)."""
    row = TABLE1[axis]
    radius = math.sqrt(TABLE8_JA[axis] / (row.m + row.m_prime))
    ja = row.m_prime * radius ** 2 * j_scale
    kt = 0.5
    rate = HELD_RATE if held else 1.0
    return TwoMassParams(kt=kt, ja=ja, vg=rate * ja / kt, mass=row.m,
                         ks=(2 * math.pi * row.eq3) ** 2 * row.m * ks_scale,
                         lead=2 * math.pi * radius)


def ring_hz(drive: TwoMassParams, periods: int = 6) -> float:
    """The frequency (Hz) the drive's reference model rings at after a deflection of 1000
    counts at rest, the position loop open (the D/A at 0 V): from the upward zero crossings
    of the deflection over ``periods`` periods of its free mode."""
    model = TwoMassDriveModel(PlantParams(kp=1.0, tm=0.0).gain, **drive.ports())
    model.deflection = 1000 << FRAC_BITS
    cycles = round(periods * drive.clock_hz / drive.held_hz)
    s = np.empty(cycles)
    for k in range(cycles):
        model.cycle(1 << (model.dac_bits - 1))
        s[k] = model.deflection
    up = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
    return (len(up) - 1) / ((up[-1] - up[0]) / drive.clock_hz)


def jk_curve(axis: str, hz: float, j: np.ndarray) -> np.ndarray:
    """Eq. (4): the stiffness K (N/m) at which axis ``axis`` with rotating inertia ``j``
    (kg m^2) rings at ``hz`` (its free mode): K = omega^2 M J / Ja, Ja = J + R^2 M."""
    row = TABLE1[axis]
    r2 = TABLE8_JA[axis] / (row.m + row.m_prime)
    return (2 * math.pi * hz) ** 2 * row.m * j / (j + r2 * row.m)


#: The JK map's omega-curves drawn (Hz; X's free mode is 206 Hz) and the J multiples of X's
#: design at which the drive runs on X's curve.
JK_CURVES_HZ = (150.0, 206.3, 250.0)
JK_J_SCALES = (0.5, 1.0, 2.0, 4.0)


@dataclass(frozen=True)
class JkStudy:
    """X's design moved along its eq. (4) omega-curve: J, K and the frequency rung."""

    j: np.ndarray
    k: np.ndarray
    measured_hz: np.ndarray


def add_rows(sec: Section) -> JkStudy:
    """Table 1's natural frequencies and the JK map's omega-curve as rows of ``sec``."""
    for axis, row in TABLE1.items():
        free, held = table1_drive(axis), table1_drive(axis, held=True)
        f_free, f_held = ring_hz(free), ring_hz(held)
        ok = (abs(f_free / free.free_hz - 1) < 0.02 and abs(f_held / held.held_hz - 1) < 0.02
              and abs(f_held / f_free - row.ratio) <= 0.01)
        sec.row(f"Table 1, {axis.upper()} axis (M {row.m:g} kg, M' {row.m_prime:g} kg): the "
                "two-mass drive's natural frequency, motor free and motor held",
                f"eq. (2) {row.eq2} Hz, eq. (3) {row.eq3} Hz, ratio {row.ratio}",
                f"free {f_free:.1f} Hz (sqrt(Ks / M_eq) {free.free_hz:.1f}), held {f_held:.1f} "
                f"Hz (sqrt(Ks / M) {held.held_hz:.1f}), ratio {f_held / f_free:.3f}",
                "each within 2% of its formula; ratio within 0.01 of Table 1's", ok, kind="number")
    base = table1_drive("x")
    j = base.ja * np.array(JK_J_SCALES)
    k = jk_curve("x", TABLE1["x"].eq2, j)
    measured = np.array([ring_hz(table1_drive("x", j_scale=s, ks_scale=kk / base.ks))
                         for s, kk in zip(JK_J_SCALES, k, strict=True)])
    spread = float(np.abs(measured / TABLE1["x"].eq2 - 1).max())
    sec.row("JK map (X axis): J and K moved along eq. (4)'s omega-curve of 206.3 Hz, "
            f"J x {', '.join(f'{s:g}' for s in JK_J_SCALES)}",
            "K = omega^2 M (J / Ja): one natural frequency along the curve (a study; the "
            "paper's map is a figure)",
            "rings at " + ", ".join(f"{f:.1f}" for f in measured) + " Hz",
            "each within 2% of 206.3 Hz", spread < 0.02, kind="quoted")
    sec.text.append(
        "The feed drive of the paper's Fig. 1 runs as the two-mass drive (motor side J, the "
        "screw's axial stiffness Ks, table mass M) on Table 1's axes: M and M' = J / R^2 as "
        "printed, Ks from the eq. (3) frequency read as Hz (Ks = (2 pi f)^2 M; the paper gives "
        "no unit, and the ratios do not depend on it), the lead from Table 8's Ja = J + R^2 M "
        f"(X {1e3 * base.lead:.2f} mm). The drive's reference model (cycle-equal to its "
        "gateware) is deflected by 1000 counts at rest and rings: with the velocity loop "
        "weak (1/s, the motor's side free) at the free mode sqrt(Ks / M_eq), "
        "M_eq = M M' / (M + M'), and with it stiff (2e5/s, the motor held) at sqrt(Ks / M). "
        "Read with a correction: eq. (1) prints omega where omega^2 is meant, and eq. (2) J / "
        "Ja where Table 1 needs Ja / J; so read, eq. (2) is the free mode and eq. (4) follows "
        "from it. Table 1's Z row is not self-consistent: its printed M and M' give the ratio "
        "0.922 (its frequencies 0.932, as M' = 6998 kg would). The JK map proper (the largest "
        "servo stiffness over J and K, the paper's Figs. 5 to 7) needs the maker's servo "
        "limits and is not drawn; the figure shows eq. (4)'s omega-curves and the drive run "
        "along one of them.")
    return JkStudy(j, k, measured)


def plot_jk(ax, study: JkStudy) -> None:
    """The JK map's omega-curves (eq. (4)) and the drive's points on X's."""
    j = np.linspace(0.2, 5.0, 200) * table1_drive("x").ja
    for hz in JK_CURVES_HZ:
        ax.plot(1e3 * j, jk_curve("x", hz, j) / 1e6, lw=0.8, label=f"omega {hz:g} Hz (eq. (4))")
    ax.plot(1e3 * study.j, study.k / 1e6, "ko", ms=4,
            label="runs: " + ", ".join(f"{f:.0f}" for f in study.measured_hz) + " Hz")
    ax.set(title="JK map, X axis: omega-curves", xlabel="J (g m^2)", ylabel="K (N/um)")
    ax.legend(fontsize=7)
