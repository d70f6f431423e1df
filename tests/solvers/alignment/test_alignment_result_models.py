"""The result's models made without validation (``finalize._trusted``) against pydantic's own ``model_construct``."""

import gc

from plantsolve.schemas.alignment import ComponentResult, ConnectionResult, Port, Transform
from plantsolve.solvers.alignment import finalize


def _same(made, want):
    assert type(made) is type(want)
    assert list(made.__dict__.items()) == list(want.__dict__.items())
    assert made.model_fields_set == want.model_fields_set
    assert made.model_dump_json(by_alias=True) == want.model_dump_json(by_alias=True)


def test_trusted_models_are_those_model_construct_makes_field_for_field():
    port = {"position": [1.0, 2.0, 3.0], "direction": [0.0, 0.0, 1.0]}
    _same(finalize._trusted(Port)(**port), Port.model_construct(**port))
    tr = {"dual_quaternion": [1.0, 0, 0, 0, 0, 0.5, 0, 0], "rotation": [1.0, 0, 0, 0], "translation": [1.0, 0, 0]}
    _same(finalize._trusted(Transform)(**tr), Transform.model_construct(**tr))
    comp = {"id": "P1", "ports": [Port.model_construct(**port)], "transform": Transform.model_construct(**tr),
            "displacement": 1.5, "rotation_angle": 0.25, "length_change": None, "up": [0.0, 0.0, 1.0]}
    _same(finalize._trusted(ComponentResult)(**comp), ComponentResult.model_construct(**comp))
    conn = {"from_": ("P1", 0), "to": ("P2", 1), "position_error": 0.0, "angle_error": 0.1, "cut": False}
    _same(finalize._trusted(ConnectionResult)(**conn), ConnectionResult.model_construct(**conn))


def test_the_collector_pause_resumes_only_what_was_running():
    assert gc.isenabled()
    with finalize._no_cycle_collection():
        assert not gc.isenabled()
    assert gc.isenabled()
    gc.disable()
    try:
        with finalize._no_cycle_collection():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_a_solved_networks_models_hold_their_fields_in_declaration_order():
    from plantsolve.solvers.alignment.solve import solve
    from plantsolve.solvers.alignment.synthetic import grid_network

    res = solve(grid_network(3, 3, valve_every=7, tie_ins=((0, 0), (2, 2)), seed=1)).result
    for model in (res.components[0], res.components[0].transform, res.components[0].ports[0], res.connections[0]):
        assert list(model.__dict__) == list(type(model).model_fields)
        assert model.model_fields_set == set(type(model).model_fields)
