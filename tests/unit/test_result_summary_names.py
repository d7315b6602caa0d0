"""The result's summary table keeps its columns aligned for long parameter names."""

import numpy as np

from aeroid.estimation import EstimationResult


def test_long_table_point_names_keep_the_columns_aligned():
    result = EstimationResult(
        estimator="x", theta=np.array([-0.9, -11.8]), names=("Cx@M1.925", "Cza"),
        stderr=np.array([0.01, 0.2]), covariance=None, cost=1.0, success=True, message="",
        warnings=(), n_evaluations=1, n_iterations=1, wall_time_s=0.1)
    lines = result.summary().splitlines()
    table = lines[lines.index(next(x for x in lines if x.strip().startswith("coef"))):]
    # every row ends its estimate column at the same character as the header
    ends = {line.index(word) + len(word) for line, word in
            zip(table, ("estimate", "-0.9", "-11.8"), strict=True)}
    assert len(ends) == 1
    assert table[1].split() == ["Cx@M1.925", "-0.9", "0.01"]
