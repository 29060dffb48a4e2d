"""The full-state route: discovery where every state is measured at every step.

It reads dense trajectories of the eight states (a shipped case's ``full`` sensor set, or
your own complete table), tests each state equation in weak form against the estimated
noise, screens and fits hypotheses in rounds, and writes a
:class:`..core.outcome.Outcome` (rounds, gap on held-out trajectories, noise floor)
for the findings.  It imports the shared core (:mod:`costa.discover.core`), never the
sparse route.
"""
