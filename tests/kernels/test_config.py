"""kernels._config: numba's optimisation level, -O2 unless the user's environment sets one."""
import os
import subprocess
import sys

import pytest

CHILD = ("import numba.core.config as c, proxyshade.kernels.random, os; "
         "print(int(c.OPT), os.environ['NUMBA_OPT'])")


@pytest.mark.parametrize("env_opt, expected", [(None, "2 2"), ("3", "3 3"), ("1", "1 1")])
def test_optimisation_level_default_and_user_setting(env_opt, expected):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_OPT"}
    if env_opt is not None:
        env["NUMBA_OPT"] = env_opt
    out = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True)
    # the level the kernels compile at, and the one worker processes inherit
    assert out.stdout.split("\n")[0] == expected
