"""Output-error's constants: estimable initial-state components, names, limits (private).

Read by :mod:`baselines.output_error` (which re-exports them) and by the windows fit
(:mod:`baselines._oe_windows`), which shares output-error's sample limit.
"""

from aeroid.model import STATE_NAMES

#: Initial-state components that can be estimated: the rates p, q, r
#: (``estimate_initial_state``) and the velocities u, v, w (``estimate_initial_velocity``).
#: The attitude (phi, theta) enters only through gravity and psi not at all, so they are
#: taken from the first measured sample, except with GNSS velocity in the likelihood
#: (``aiding``: :data:`baselines._oe_aiding.X0_ANGLES`).
X0_RATES = (3, 4, 5)
X0_VELOCITIES = (0, 1, 2)
X0_NAMES = tuple(f"{name}0" for name in STATE_NAMES)  # u0 ... psi0
#: Floor of each R_jj as a fraction of the channel's mean square: keeps the weights
#: finite on noise-free data, far below any real noise level.
R_FLOOR_REL = 1e-24
#: Names of the six accelerometer-position components.
POSITION_NAMES = ("rx1", "ry1", "rz1", "rx2", "ry2", "rz2")
#: Largest actuator delay accepted [s] (a starting value or a fixed delay): a tenth of a
#: second is far beyond any fin actuator and beyond the fits' record lengths' sense.
MAX_DELAY_S = 0.1
#: Longest record fitted whole: the Jacobian holds every sample (the model is evaluated
#: in pieces of :data:`baselines._oe_record.PIECE_SAMPLES`). Measured on the reference
#: airframe (Gaussian IMU, benchmarks/results/oe_long.md): 20 000 samples 1.9 s CPU per
#: warm fit, +70 MB at the first fit; 50 000 samples 7.0 s CPU, +169 MB (~2.5 kB per
#: sample; before the pieces, 20 001 samples took 19 s and +510 MB with the model's
#: build). A longer log: fit windows of it.
MAX_SAMPLES = 50_000

__all__ = ["MAX_DELAY_S", "MAX_SAMPLES", "POSITION_NAMES", "R_FLOOR_REL", "X0_NAMES",
           "X0_RATES", "X0_VELOCITIES"]
