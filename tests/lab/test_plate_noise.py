"""The plates' noise read from their samples, against the noise drawn into them."""

from __future__ import annotations

import numpy as np
import pytest

from colloc.lab.noise import moment_noise, off_plate_noise


def _stance(n: int, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A foot loaded half of each 1.2 s stride: its vertical load and its moment (the centre
    of pressure walking 0.25 m forward under the load)."""
    t = np.arange(n) / rate
    phase = np.mod(t / 1.2, 1.0)
    loaded = phase < 0.6
    load = np.where(loaded, 700.0 * np.sqrt(np.clip(np.sin(np.pi * phase / 0.6), 0.0, None)), 0.0)
    moment = load * (0.1 + 0.25 * phase / 0.6)
    return t, load, moment


@pytest.mark.parametrize("rate", [100.0, 1000.0])
def test_a_moment_from_a_centre_of_pressure_reads_its_noise_under_load(rate):
    rng = np.random.default_rng(3)
    _, load, moment = _stance(6000, rate)
    noisy = moment + rng.normal(0.0, 1.0, moment.size)
    # as a MOT gives it: no centre of pressure off the plate, so the moment is exactly zero
    from_centre = np.where(load > 0, noisy, 0.0)
    assert moment_noise([(from_centre, load)]) == pytest.approx(1.0, rel=0.1)
    # the off-plate reading this replaces sees almost nothing there
    assert off_plate_noise([(from_centre, load)]) < 0.5
    # a moment channel recorded throughout (a tab export's MomZ) is read off the plate
    assert moment_noise([(noisy, load)]) == pytest.approx(1.0, rel=0.1)


def test_a_filtered_plate_shows_no_noise_and_its_moment_none_either():
    import pandas as pd

    from colloc.lab.raw_tables import plate_noise

    t, load, moment = _stance(6000, 1000.0)
    # filtered before export: forces exactly zero off the plate, the moment's small smooth
    # remnant beside it (a centre of pressure times a force below the unloaded threshold)
    remnant = np.where(load > 0, moment, 1e-3 * np.sin(t))
    columns = {"time": t}
    for side in ("right", "left"):
        columns |= {f"{side}_force_x": 0.1 * load, f"{side}_force_y": load,
                    f"{side}_moment": remnant}  # fmt: skip
    found = plate_noise(pd.DataFrame(columns))
    assert found == {"force": 0.0, "moment": 0.0}  # both left to colloc's defaults
    assert moment_noise([(remnant, load)]) > 0.0  # what reading it alone would give


def test_a_moment_never_recorded_has_no_noise():
    _, load, _ = _stance(600, 100.0)
    assert moment_noise([(np.zeros(600), load)]) == 0.0


@pytest.mark.parametrize("rate", [100.0, 1000.0])
def test_a_moment_whose_own_motion_passes_for_noise_is_not_read(rate):
    """At 100 Hz a moment under load that rings (the contact's heel-to-toe transfer, here 25
    Hz of 15 N m) has second differences far above its 1 N m of noise: read there, it gave
    a noise 10-18 times too large on a skin export. White noise spreads alike in the second
    and fourth differences, this does not: the moment is left to the default (0 here). At
    1000 Hz the same ringing is smooth beside the noise, which is read."""
    rng = np.random.default_rng(5)
    t, load, moment = _stance(6000, rate)
    ringing = np.where(load > 0, 15.0 * np.sin(2 * np.pi * 25.0 * t), 0.0)
    noisy = np.where(load > 0, moment + ringing + rng.normal(0.0, 1.0, t.size), 0.0)
    second = np.diff(noisy, 2)[(load[1:-1] > 0) & (load[:-2] > 0) & (load[2:] > 0)]
    if rate == 100.0:
        assert np.std(second) / np.sqrt(6.0) > 5.0  # what the second differences alone say
        assert moment_noise([(noisy, load)]) == 0.0
    else:
        assert moment_noise([(noisy, load)]) == pytest.approx(1.0, rel=0.15)
