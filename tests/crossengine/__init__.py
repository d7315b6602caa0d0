"""Cross-engine tests: flights of a rolling airframe made by JSBSim (issue 10, item 6).

``jsbsim_flight.make_flight(config)`` writes a JSBSim aircraft whose aerodynamics are
aeroid's model (``_aircraft``, ``rolling_airframe.xml``), flies it (``_engine``) and
returns aeroid's view of the flight plus the engine's truth; ``prototype`` (with the
compiled ``_kernel``) holds the research prototype of the model inputs aeroid does not
have yet; ``measure`` tabulates what each one changes (``results.md``).
"""
