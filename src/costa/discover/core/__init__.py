"""The shared core of both discovery routes: what an explanation is and how a closed form is fitted.

Hypotheses (a wrong part, a missing flow, a property, an input) and their term library,
the sparse regression with its grouped bootstrap, the kept terms' intervals, the order in
which equally good explanations are named, the noise of densely sampled signals and the
settings.  It reads arrays and a :class:`costa.physics.CellModel` and writes nothing.
Nothing in it imports a route; the routes import it.
"""
