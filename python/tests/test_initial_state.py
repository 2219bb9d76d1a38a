"""Scene.with_initial_state: the cloth starts where it is given, settled when not at rest."""

from __future__ import annotations

import numpy as np
import pytest

import clothopt


def test_with_initial_state_starts_there_and_settles_what_is_not_at_rest():
    scene = clothopt.Scene.load("u_obstacle")
    np.testing.assert_array_equal(scene.start(), scene.simulate().states[0])
    end = scene.simulate().states[-1]
    # The end of a rollout is not at rest (its last step moved it): settled, grippers held.
    settled = scene.with_initial_state(end)
    start = settled.start()
    assert start.shape == (scene.n_particles, 3)
    assert np.abs(start - end).max() > 1e-3
    # A start at rest is used as given: step 0 is it, bit for bit.
    again = scene.with_initial_state(start)
    np.testing.assert_array_equal(again.start(), start)
    np.testing.assert_array_equal(again.simulate().states[0], start)
    assert again.to_dict()["cloth"]["initial_state"]["positions"][5] == list(start[5])
    with pytest.raises(ValueError, match="cloth.initial_state: not at rest"):
        scene.with_initial_state(end, settle=False)
    with pytest.raises(ValueError, match=r"positions: expected shape \(100, 3\)"):
        scene.with_initial_state(np.zeros((99, 3)))
