"""Exit codes of the ``kfio`` CLI (a public contract: tools test them)."""

STABLE = 0  #: verdict stable, or a non-verdict command succeeded
UNSTABLE = 1  #: verdict unstable
INVALID_INPUT = 2  #: the request broke a rule; one message on stderr names the field
BOUNDARY = 3  #: verdict on the boundary |alpha|^2 sigma = 1 (Theorem 1's gap)
BUDGET = 4  #: the work did not finish within its budget
NUMERICAL = 5  #: a numerical step could not be completed or certified (kfio refuses rather than guess)
CANNOT_SERVE = 6  #: ``kfio serve`` could not start (port in use, invalid address, the app failed to start)
SWEEP_ERRORS = 8  #: kfio sweep finished, and some points have an error row (the table says which)
MISSING_DEPENDENCY = 9  #: a package this feature needs is not installed (not the input's fault)
INTERNAL = 70  #: anything else: a bug (EX_SOFTWARE)
BROKEN_PIPE = 141  #: standard output was closed by its reader (128 + SIGPIPE, as a shell reports it)

BY_VERDICT = {"stable": STABLE, "unstable": UNSTABLE, "boundary": BOUNDARY}
