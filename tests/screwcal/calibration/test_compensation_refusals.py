"""Why a target is refused does not turn on the last bits of its reference solution."""

from dataclasses import replace

import numpy as np

from screwcal.calibration.correction import compensate
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.robots import builtin_model

# KR 16 targets of benchmarks/program_filter.py (joint 3 near -5 deg: the arm near stretched)
# and that benchmark's calibrated model (0.3 mm moves of the axes' points)
Q_REF = [[-1.613774364557505, -1.8617927133647212, -0.08277092378419937, 2.2423399297967945,
          0.3626204931283237, -1.5039201244257607],
         [-2.043217558970469, -1.0144097668722787, -0.06779162397063732, 2.0470882240942982,
          0.7170998098658237, -1.3997109626884394]]
POINT_MOVES_MM = [[-0.3268279593903846, -0.17801933384636232, 0.17958933842199828],
                  [0.7104037967142314, -0.5532102122226326, -0.12264678373490709],
                  [0.24162393592254608, 0.3673047315894731, -0.235257549577145],
                  [0.6171405318090307, -0.1682211350866337, 0.36478086936896115],
                  [0.09581753087074885, 0.002933278687678139, 0.2778519762071602],
                  [0.28140408213961077, -0.14098571850029967, -0.27791988389317246]]


def test_a_gauss_newton_run_off_to_many_turns_is_not_named_as_the_solution():
    """Gauss-Newton from the reference runs off along the singular direction (joint 6 at
    -1366 and 5500 deg): the refusal used to name those joints as 'outside its limits', or,
    with the reference a few 1e-12 rad different, 'cannot reach'. Levenberg-Marquardt from the
    reference misses the target too: out of the calibrated robot's reach there, said with how
    near it gets."""
    nominal = builtin_model("kr16")
    calibrated = replace(nominal, axis_points_mm=nominal.axis_points_mm + POINT_MOVES_MM)
    q_ref = np.array(Q_REF)
    wanted = flange_kinematics(nominal, q_ref)
    for nudge in (0.0, 1e-12, -1e-12):
        comp = compensate(calibrated, nominal, wanted, q_ref + nudge, frame="base",
                          strict=False)
        assert [k for k, _ in comp.refused] == [0, 1]
        for _, why in comp.refused:
            assert why.startswith("the calibrated robot cannot reach it near the nominal "
                                  "solution (its nearest pose there is "), why
        np.testing.assert_array_equal(comp.q_rad, q_ref + nudge)  # refused rows: the reference
