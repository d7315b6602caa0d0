"""Measure the reconstruction on the JSBSim suite log over sensor seeds (issue 22).

``python -m tests.crossengine.suite_measure FIRST LAST`` prints, per seed, the fraction
of samples of u v w phi theta psi within 3 sd of JSBSim's truth (the smallest of the
six), the residual check of each aiding source and the reconstruction's time, then how
many seeds meet ``test_suite_log.WITHIN_3SD`` and the same with an undeclared 2 ms INS
delay (a known-wrong log).
"""

from __future__ import annotations

import dataclasses
import sys
import time

from aeroid.reconstruction import reconstruct

from .test_suite_log import INS_LATE_S, WITHIN_3SD, jsbsim_suite_log, within_3sd


def main(first: int, last: int) -> None:
    """Print the measurement for seeds ``first..last``."""
    passed = refused_wrong = 0
    for seed in range(first, last + 1):
        sim, data = jsbsim_suite_log(seed)
        start = time.process_time()
        rec = reconstruct(sim.log)
        cpu = time.process_time() - start
        fractions = within_3sd(rec, data)
        ins = sim.log["ins"]
        late = dataclasses.replace(ins, t=ins.t - INS_LATE_S)
        wrong = within_3sd(reconstruct(dataclasses.replace(
            sim.log, groups={**sim.log.groups, "ins": late})), data)
        passed += min(fractions.values()) >= WITHIN_3SD
        refused_wrong += min(wrong.values()) < WITHIN_3SD
        nis = " ".join(f"{k} {v['mean_nis_per_dof']:.2f}{'' if v['consistent'] else '!'}"
                       for k, v in rec.nis.items())
        print(f"seed {seed}: min within-3sd {min(fractions.values()):.3f} "
              f"(INS late: phi {wrong['phi']:.3f}); NIS {nis}; {cpu:.1f} s CPU", flush=True)
    n = last - first + 1
    print(f"correct log passes in {passed}/{n} seeds; INS-late log refused in "
          f"{refused_wrong}/{n}")


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]))
