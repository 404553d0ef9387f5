r"""Synthetic approach curves with a known contact point and force law (docs/curves.md).

A curve is written the way an AFM records it: piezo height, force from the cantilever's
deflection, plus a baseline offset and tilt, deflection drift and white thermal noise.
"""

from dataclasses import asdict, dataclass

import numpy as np

from turgorbayes.physics import bulge

__all__ = [
    "DEFAULT_ACQUISITION",
    "Acquisition",
    "SyntheticCurve",
    "bulge_force",
    "cell_force",
    "synthetic_curve",
    "write_curve",
]

#: Boltzmann constant times 298 K [J].
KT = 1.380649e-23 * 298.0


@dataclass(frozen=True)
class Acquisition:
    """How a synthetic curve is recorded (SI units).

    Attributes
    ----------
    spring_constant : float [N/m]
        Cantilever spring constant ``k`` (the paper's 0.011 N/m).
    sensitivity : float [m/V]
        Deflection sensitivity (metadata only: forces are written in N).
    speed : float [m/s]
        Piezo approach speed.
    rate : float [Hz]
        Sampling rate (``speed / rate`` is the piezo step, 0.5 nm by default).
    noise_sd : float [N]
        White force noise; the default is the thermal limit ``sqrt(kB T k)`` (6.7 pN).
    free_length : float [m]
        Piezo travel before contact (the non-contact baseline).
    offset : float [N]
        Deflection offset of the baseline.
    tilt : float [N/m]
        Baseline slope in force per piezo travel (interference, drag).
    drift : float [N/s]
        Deflection drift in force per second (linear in time, so within one approach it adds
        to the tilt).
    height_top : float [m]
        Piezo height at the start of the approach (heights fall as the tip approaches).
    deflection_gain : float [-]
        Recorded over true deflection: the file's ``sensitivity`` over the true one (1: a
        correct sensitivity). Every recorded force is this factor times the true one; on a
        hard surface it is the slope of deflection on piezo travel (docs/curves.md, Glass
        reference).
    """

    spring_constant: float = 0.011
    sensitivity: float = 50e-9
    speed: float = 1e-6
    rate: float = 2000.0
    noise_sd: float = float(np.sqrt(KT * 0.011))
    free_length: float = 400e-9
    offset: float = -0.3e-9
    tilt: float = 5e-5
    drift: float = 5e-12
    height_top: float = 10e-6
    deflection_gain: float = 1.0

    def as_dict(self):
        return asdict(self)


#: The default acquisition (the paper's cantilever at its thermal noise).
DEFAULT_ACQUISITION = Acquisition()


@dataclass(frozen=True)
class SyntheticCurve:
    """A simulated approach and its truth.

    Attributes
    ----------
    data : dict of ndarray
        afmformats columns: ``force`` [N], ``height (measured)``, ``height (piezo)`` [m],
        ``segment`` (0: approach), ``time`` [s].
    metadata : dict
        afmformats metadata (spring constant, sensitivity, speed, rate, ...).
    contact_height : float [m]
        Piezo height at which the tip touches the sample.
    max_depth : float [m]
        Indentation at the last point of the approach.
    """

    data: dict
    metadata: dict
    contact_height: float
    max_depth: float


def cell_force(h, k_c, h_ref, a=0.1):
    r"""Stiffening force law of a cell body whose secant stiffness at ``h_ref`` is ``k_c``.

    .. math:: F(h) = k_c\,h\,(h/h_\mathrm{ref})^a, \qquad F(h_\mathrm{ref})/h_\mathrm{ref} = k_c

    (a power law with a small exponent ``a`` mimics the FE curves' mild stiffening; the
    secant at ``h_ref = R_c/20`` is the FE table's definition, docs/physics.md).

    Parameters
    ----------
    h : array_like [m]
        Indentation, >= 0.
    k_c : float [N/m]
        Secant stiffness at ``h_ref``.
    h_ref : float [m]
        Reference depth (``R_c/20``).
    a : float [-]
        Stiffening exponent.

    Returns
    -------
    ndarray [N]
    """
    h = np.maximum(np.asarray(h, float), 0.0)
    return k_c * h * (h / h_ref) ** a


def bulge_force(h, P, R_b, alpha=bulge.DEFAULT_ALPHA):
    r"""Force of a cone indenting a liquid-membrane bulge to depth ``h``.

    .. math:: F(h) = P R_b^2\, f(h/R_b)

    with the reduced force ``f`` of :func:`turgorbayes.physics.bulge.reduced_force` (docs/physics.md,
    Bulge model); its secant ``F(h_b)/h_b`` is ``k_b`` of the cell-data file.

    Parameters
    ----------
    h : array_like [m]
        Indentation, in [0, (1 + cot alpha) R_b).
    P : float [Pa]
        Pressure.
    R_b : float [m]
        Bulge radius.
    alpha : float [rad]
        Cone half-angle.

    Returns
    -------
    ndarray [N]
    """
    h = np.maximum(np.asarray(h, float), 0.0)
    return P * R_b**2 * bulge.reduced_force(h / R_b, alpha)


def _depth_of_travel(travel, force_law, max_depth, k):
    """Indentation ``h`` [m] at piezo travel past contact ``travel`` [m], by inverting
    ``travel = h + F(h)/k`` (monotone) on a dense grid of depths."""
    h = np.linspace(0.0, max_depth, 4001)
    return np.interp(travel, h + force_law(h) / k, h)


def synthetic_curve(force_law, max_depth, acquisition=DEFAULT_ACQUISITION, seed=0, contact_jitter=20e-9):
    """Simulate one approach curve indenting a sample with force law ``force_law`` to
    ``max_depth``.

    The piezo moves the cantilever base by ``z`` toward the sample; past the contact point
    ``z_0`` the tip indents by ``h`` with ``z - z_0 = h + F(h)/k``. The recorded force is
    ``g (F(h) + offset + tilt z + drift t + noise)``, ``g`` the acquisition's
    ``deflection_gain`` (1 unless the sensitivity is deliberately wrong).

    Parameters
    ----------
    force_law : callable
        ``F(h)`` [N] of the indentation ``h`` [m], vectorized, ``F(0) = 0``.
    max_depth : float [m]
        Indentation at the end of the approach (where the setpoint stops it).
    acquisition : Acquisition
        Cantilever, sampling, baseline and noise.
    seed : int
        Seed of the noise and of the contact point's jitter.
    contact_jitter : float [m]
        The free travel is ``free_length`` plus a uniform draw in [0, ``contact_jitter``).

    Returns
    -------
    SyntheticCurve
    """
    a = acquisition
    rng = np.random.default_rng(seed)
    z0 = a.free_length + rng.uniform(0.0, contact_jitter)
    k = a.spring_constant
    z_end = z0 + max_depth + float(force_law(np.array(max_depth))) / k
    step = a.speed / a.rate
    z = np.arange(0.0, z_end + 0.5 * step, step)
    h = _depth_of_travel(z - z0, force_law, max_depth, k)
    t = z / a.speed
    force = a.deflection_gain * (force_law(h) + a.offset + a.tilt * z + a.drift * t
                                 + a.noise_sd * rng.standard_normal(z.size))
    height = a.height_top - z
    data = {"force": force, "height (measured)": height, "height (piezo)": height.copy(),
            "segment": np.zeros(z.size, dtype=np.uint8), "time": t}
    metadata = {"imaging mode": "force-distance", "spring constant": k,
                "sensitivity": a.sensitivity, "speed approach": a.speed, "rate approach": a.rate,
                "point count": int(z.size), "segment count": 1,
                "instrument": "turgorbayes synthetic", "enum": 0}
    return SyntheticCurve(data=data, metadata=metadata, contact_height=a.height_top - z0,
                          max_depth=float(max_depth))


def write_curve(curve, path, calibration=True):
    """Write ``curve`` with afmformats' own exporter (``.tab``: tab-separated values with a
    JSON metadata block; ``.h5``: afmformats HDF5).

    Parameters
    ----------
    curve : SyntheticCurve
    path : str or pathlib.Path
        Ends in ``.tab`` or ``.h5``.
    calibration : bool
        False leaves the spring constant and sensitivity out of the metadata (a file whose
        calibration is missing).
    """
    import afmformats

    metadata = dict(curve.metadata, path=str(path))
    if not calibration:
        metadata.pop("spring constant")
        metadata.pop("sensitivity")
    fmt = "h5" if str(path).endswith(".h5") else "tab"
    afmformats.AFMForceDistance(curve.data, metadata).export_data(path, fmt=fmt)
