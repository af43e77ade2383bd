"""The peers' own implementations as diffbench methods: PyNumDiff and ``derivative``.

Each module here is a plugin (an entry point of the group ``diffbench.methods`` declared by
diffbench's own ``pyproject.toml``) whose methods are named ``<package>.<function>``, e.g.
``pynumdiff.spectraldiff`` or ``derivative.kalman``. Each adapter declares the peer's own
parameters (names and units as the peer spells them) with admissible and tuning ranges, so the
same tuners tune them, and calls the peer exactly as a user would; what it returns is the
peer's result, untouched. Where the peer has no second derivative, ẍ is the method applied
again, with the same parameters, to its own ẋ (the class says so in ``second_derivative``).

If a peer package is not installed (``pip install 'diffbench[peers]'`` installs them), its
module registers nothing and records how to get it, so everything else works and an unknown
``pynumdiff.*`` name says how to install it.
"""

PEERS_EXTRA = "pip install 'diffbench[peers]'"
"""How to install the peer packages the adapters call."""
