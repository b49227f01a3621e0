"""Calibration of the GPR from measured platform poses, measurement planning and the accuracy budget.

Pure numpy/scipy (no ROS). The engines work on any :class:`~.model.PoseModel` (named parameters, a forward
model of the platform pose); :mod:`.core_model` binds them to the kinematics core. Modules:

* :mod:`.model`: parameters, the pose-model interface, pose errors, the finite-difference Jacobian;
* :mod:`.measurements`: measurement files (CSV) and their checks; :mod:`.files`: bounded reading, safe writing;
* :mod:`.identifiability`: scaled singular values, unidentifiable combinations, parameters held at nominal;
* :mod:`.fitting`: the bounded Levenberg-Marquardt from several starts and its convergence; :mod:`.quality`: the
  cross-validation, the bias of the held parameters, the gate;
* :mod:`.identification`, :mod:`.results`: weighted nonlinear least squares, standard errors, residuals before,
  after and cross-validated; :mod:`.residual_plot`, :mod:`.plot`: ``gpr calibrate --plot``'s data and figure;
* :mod:`.frames`: registration (the tracker's frame and the target identified with the geometry); :mod:`.arm`: the
  arms' link lengths, zero offsets and wafer centre;
* :mod:`.plan`: measurement configurations that make the identification well conditioned;
* :mod:`.tolerances`, :mod:`.budget`, :mod:`.monte_carlo`: the tolerance table and the accuracy budget (linearised,
  Monte Carlo);
* :mod:`.synthetic`: synthetic measurements of a known machine; :mod:`.core_model`: the core binding, its datum and
  the calibrated geometry file; :mod:`.demo`: the ``make demo`` step; :mod:`.cell`: the worked example's raw data.

See docs/calibration.md.
"""
