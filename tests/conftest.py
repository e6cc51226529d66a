"""The test session's settings.

A run that compiles starts a compile helper, a second process that compiles part of what the
run needs meanwhile (attitude/_compiling.py). The suite's workers already fill the cores, so
it is off here unless set (as in ``attitude warmup``'s workers); the tests of the helper turn
it on in the processes they start (tests/test_compiling.py, tests/test_user_kernels.py).
"""

import os

os.environ.setdefault("ATTITUDE_COMPILE_HELPER", "0")
