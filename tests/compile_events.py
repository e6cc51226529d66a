"""For the tests that count what numba compiles in a process they start."""

import textwrap

#: The start of a child script: ``compiled``, the qualified names of the functions numba
#: compiles in it (its ``numba:compile`` events).
LISTEN = textwrap.dedent(
    """
    from numba.core import event
    compiled = []
    class L(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data["dispatcher"].py_func.__qualname__)
        def on_end(self, ev):
            pass
    event.register("numba:compile", L())
    """
)
