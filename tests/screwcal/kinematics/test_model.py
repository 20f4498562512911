import gc
from dataclasses import replace

from screwcal.kinematics.model import once_per_object
from screwcal.kinematics.robots import irb1600


def test_once_per_object_computes_once_and_forgets_the_object():
    calls = []

    @once_per_object
    def table(model):
        calls.append(model)
        return model.limits.sum()

    model = irb1600()
    assert table(model) == table(model) and len(calls) == 1
    other = replace(model, limits=model.limits * 0.5)  # a changed model is a new object
    assert table(other) == 0.5 * table(model) and len(calls) == 2
    cells = dict(zip(table.__code__.co_freevars, table.__closure__, strict=True))
    cache = cells["cache"].cell_contents
    assert len(cache) == 2
    calls.clear()
    del other
    gc.collect()
    assert len(cache) == 1  # forgotten with its model
    table(model)
    assert calls == []


def test_a_derived_model_is_read_only_like_a_validated_one():
    """A test once wrote a collision into a derived true robot's joint zeros in place; caches
    keyed by the model object never saw it. Derived arrays are read-only views."""
    import numpy as np
    import pytest

    zero = np.zeros(6)
    model = irb1600().derived(joint_zero=zero)
    with pytest.raises(ValueError, match="read-only"):
        model.joint_zero[1] += 0.1
    zero[1] = 0.5  # the caller's own array stays its own to write
    with pytest.raises(ValueError, match="read-only"):
        model.with_frames(tool=np.eye(4)).tool[0, 3] = 1.0
