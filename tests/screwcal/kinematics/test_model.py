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
