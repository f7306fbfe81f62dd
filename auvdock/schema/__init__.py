"""What every validated input file shares: strict YAML and a strict pydantic base with one-line errors.

The ground floor of the settings: each stage's settings module (:mod:`auvdock.sensing.settings`,
:mod:`auvdock.estimation.settings`, :mod:`auvdock.controllers.settings`, ...) is built on it, and the
mission (:mod:`auvdock.config.mission`) gathers them.
"""
