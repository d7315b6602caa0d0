"""The noise models' per-output sd (written once) against the noise they draw."""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.flights import GaussianNoise, NoNoise, PaperNoise
from aeroid.model import ACCEL_CHANNELS, OUTPUT_CHANNELS

#: Draws per channel: the sample sd of N draws has a relative sd of about 1/sqrt(2N)
#: (Gaussian; less for the uniform): 0.16 % at 2e5, so 1 % is over six of them.
N_DRAWS = 200_000
SAMPLE_SD_RTOL = 0.01


def _drawn_sd(noise, level: np.ndarray) -> np.ndarray:
    """The sample sd of the error ``noise.corrupt`` adds to constant channels ``level``."""
    clean = {c: np.full(N_DRAWS, v) for c, v in zip(OUTPUT_CHANNELS, level, strict=True)}
    noisy = noise.corrupt(clean, np.random.default_rng(3))
    return np.array([np.std(noisy[c] - clean[c]) for c in OUTPUT_CHANNELS])


@pytest.mark.parametrize("noise", [PaperNoise(), PaperNoise(accelerations_xi=0.1, rates_xi=0.02),
                                   GaussianNoise(), GaussianNoise(accel_sd_mps2=0.2)])
def test_output_sd_is_the_sd_of_the_drawn_noise(noise):
    level = np.linspace(-40.0, 60.0, len(OUTPUT_CHANNELS))  # one level per channel
    sd = noise.output_sd(np.tile(level, (3, 1)))
    assert sd.shape == (3, len(OUTPUT_CHANNELS))
    np.testing.assert_allclose(sd[0], _drawn_sd(noise, level), rtol=SAMPLE_SD_RTOL)


def test_paper_noise_forms():
    # two samples per channel, |s| = 3 and 4: RMS 5/sqrt(2)
    outputs = np.array([[3.0] * len(OUTPUT_CHANNELS), [-4.0] * len(OUTPUT_CHANNELS)])
    noise = PaperNoise(accelerations_xi=0.06, rates_xi=0.03)
    xi = np.array([0.06 if c in ACCEL_CHANNELS else 0.03 for c in OUTPUT_CHANNELS])
    np.testing.assert_allclose(noise.output_sd(outputs),
                               np.abs(outputs) * xi / np.sqrt(3), rtol=1e-15)
    np.testing.assert_allclose(noise.output_sd(outputs, form="homoscedastic"),
                               np.tile(5 / np.sqrt(2) * xi / np.sqrt(3), (2, 1)), rtol=1e-15)
    assert np.all(NoNoise().output_sd(outputs) == 0)


@pytest.mark.parametrize("noise", [PaperNoise(), GaussianNoise(), NoNoise()])
def test_output_sd_refuses_wrong_shapes_and_forms(noise):
    with pytest.raises(ValueError, match=f"shape \\(n, {len(OUTPUT_CHANNELS)}\\)"):
        noise.output_sd(np.ones((4, len(OUTPUT_CHANNELS) - 1)))
    with pytest.raises(ValueError, match="unknown form 'relative'"):
        noise.output_sd(np.ones((4, len(OUTPUT_CHANNELS))), form="relative")
