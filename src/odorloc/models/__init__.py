"""Measurement models shared by the simulated truth (plumes) and by estimators (beliefs).

- :mod:`.base`: the :class:`~odorloc.models.base.MeasurementModel` interface
  (``log_likelihood`` for updates, ``outcome_probabilities`` for planning);
- :mod:`.poisson`: Poisson counts (log-pmf, censored classes);
- :mod:`.vergassola`: the Vergassola encounter-rate model (infotaxis; multi-UAV paper eqs. 1-3);
- :mod:`.pang_farrell`: binary detections of wind-advected puffs (indoor PF paper eqs. 6-11);
- :mod:`.gaussian`: the steady Gaussian plume with noisy or thresholded readings;
- :mod:`.lattice`: the isotropic censored-Poisson hits of infotaxis' lattice problem (OTTO),
  its constants, and translation-invariant models tabulated over lattice offsets.
"""
