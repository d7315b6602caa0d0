"""Output-error's constants: the estimable initial-state components, limits and floors.

Read by :mod:`baselines.output_error` (which re-exports them) and by the windows fit
(:mod:`baselines._oe_windows`), which shares output-error's sample limit.
"""

#: Initial-state components that can be estimated: the rates p, q, r
#: (``estimate_initial_state``) and the velocities u, v, w (``estimate_initial_velocity``).
#: The attitude (phi, theta) enters only through gravity and psi not at all, so they are
#: taken from the first measured sample.
X0_RATES = (3, 4, 5)
X0_VELOCITIES = (0, 1, 2)
X0_NAMES = ("u0", "v0", "w0", "p0", "q0", "r0")
#: Floor of each R_jj as a fraction of the channel's mean square: keeps the weights
#: finite on noise-free data, far below any real noise level.
R_FLOOR_REL = 1e-24
#: Names of the six accelerometer-position components.
POSITION_NAMES = ("rx1", "ry1", "rz1", "rx2", "ry2", "rz2")
#: Largest actuator delay accepted [s] (a starting value or a fixed delay): a tenth of a
#: second is far beyond any fin actuator and beyond the fits' record lengths' sense.
MAX_DELAY_S = 0.1
#: Longest record fitted whole: the C model is built for the record's length and its
#: Jacobian holds every sample. Measured on the reference airframe (Gaussian IMU): 5 001
#: samples 7 s and +66 MB, 20 001 samples 19 s and +510 MB (model build and compile
#: included); 50 000 samples would take ~1.5 GB. A longer log: fit windows of it.
MAX_SAMPLES = 50_000

__all__ = ["MAX_DELAY_S", "MAX_SAMPLES", "POSITION_NAMES", "R_FLOOR_REL", "X0_NAMES",
           "X0_RATES", "X0_VELOCITIES"]
