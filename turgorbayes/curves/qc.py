"""Quality-control statuses of a force curve: ``ok`` or the reason it was rejected."""

__all__ = ["ACCEPTED", "IMPRECISE", "OK", "STATUSES", "CurveRejected"]

OK = "ok"
#: Accepted, but its standard error exceeds its own reading: kept in its cell's mean (leaving
#: out the low readings biases soft cells high), and shown as a curve to look at.
IMPRECISE = "imprecise"
#: The statuses whose stiffness a cell uses.
ACCEPTED = (OK, IMPRECISE)
#: status -> what it means (docs/curves.md, Quality control).
STATUSES = {
    OK: "the curve gave a stiffness",
    IMPRECISE: "the curve gave a stiffness whose standard error is larger than the stiffness "
               "itself (but not than the deep secant): kept in its cell's mean, since leaving "
               "out the low readings biases soft cells high; look at it",
    "unreadable_file": "afmformats could not read the file, or it has no approach segment",
    "calibration_missing": "no cantilever spring constant (or no sensitivity to rescale) in the "
                           "file and none in the manifest",
    "no_contact": "the force never rises clearly above the baseline",
    "baseline_too_short": "too few non-contact points before the contact point",
    "baseline_too_noisy": "the baseline scatter is too large a part of the force reached",
    "contact_too_close_to_end": "too few points or too little depth past the contact point",
    "coarse_sampling": "the curve reaches past the stiffness window but has too few points "
                       "in it: sampled too coarsely for the window (sample more densely)",
    "too_shallow": "the indentation never reaches the depth at which the stiffness is read "
                   "(h = R_c/20 on cells)",
    "fit_failed": "the contact-point fit did not converge or gave a non-physical result",
    "stiffness_undetermined": "the stiffness's standard error is larger than the secant over "
                              "the deepest tenth of the indentation (max_relative_error, "
                              "100 %): the force at the reading depth is within the noise",
    "not_hard_surface": "a glass reference curve whose contact part is not a straight line of "
                        "slope 0.5-1.5 (deflection on piezo travel): not a hard surface",
    "map_too_small": "a whole force map: too few curves, substrate or cell pixels for a "
                     "cross-section of the cell, or no cell above the substrate",
    "cross_section_failed": "a whole force map: the fit of the cell's cross-section did not "
                            "converge or gave a radius larger than the map",
    "no_crest_curve": "a whole force map: no crest curve gave a stiffness",
    "no_bulge": "a whole force map on a bulge row: no dome rises above the cell's fitted "
                "cylinder",
    "bulge_fit_failed": "a whole force map on a bulge row: the sphere fit of the dome did not "
                        "converge, or put its apex outside the dome or R_b beyond the map",
    "no_apex_curve": "a whole force map on a bulge row: no apex curve gave a stiffness",
}


class CurveRejected(Exception):
    """A curve failed quality control.

    Parameters
    ----------
    status : str
        A key of :data:`STATUSES`.
    detail : str
        What was measured against which limit ("baseline 12 points, need >= 50").
    """

    def __init__(self, status, detail):
        if status not in STATUSES or status in ACCEPTED:
            raise ValueError(f"unknown rejection status {status!r}")
        self.status = status
        self.detail = detail
        super().__init__(f"{status}: {detail}")
