"""Estimation: the FSE flow filter, the navigation filter and the estimation stage."""
