"""Flows with known answers: the pipeline checked against closed forms and published data.

Each case module (``sphere``, ``naca0012``, ``flapping``) builds a small OpenFOAM case with the
whale case's solver and settings, runs it, and returns a :class:`~.suite.CaseResult`: its
measured figures against their references, each with a tolerance and pass/fail.
:mod:`.suite` runs the cases, prints the table and writes ``<out>/validation.json``
(``whale-adapter validate``; docs/validation.md).
"""
