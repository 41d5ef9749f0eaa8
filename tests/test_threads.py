"""One native BLAS thread in the command's processes (issue 30 item 5), a user's own
setting kept, and the fits the same either way."""

from __future__ import annotations

import os
import subprocess
import sys

PROBE = ("from pipeline.threads import one_native_thread; one_native_thread(); "
         "import numpy; from threadpoolctl import threadpool_info; "
         "print(max(i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'))")


def _threads(**env) -> int:
    clean = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", PROBE], env={**clean, **env},
                         capture_output=True, text=True, check=True, timeout=60)
    return int(out.stdout.strip())


def test_the_command_asks_for_one_blas_thread_and_keeps_a_users_choice():
    assert _threads() == 1
    assert _threads(OPENBLAS_NUM_THREADS="2") == 2


def test_the_fits_do_not_depend_on_the_thread_count():
    import numpy as np
    from threadpoolctl import threadpool_limits

    import pipeline
    from pipeline.models import ProcessModel
    from pipeline.synth import step_record

    rec = step_record(ProcessModel("two_lags", {"K": 1.5, "T1": 8.0, "T2": 2.0}), u0=0.0,
                      changes=[(10.0, 1.0), (90.0, 0.0)], t_end=170.0, dt=0.2, y0=1.0,
                      noise=0.01)
    with threadpool_limits(limits=1):
        one = pipeline.analyse(rec).recommended.model.params
    with threadpool_limits(limits=2):
        two = pipeline.analyse(rec).recommended.model.params
    assert one.keys() == two.keys()
    assert all(np.isclose(one[k], two[k], rtol=1e-9, atol=0) for k in one)
