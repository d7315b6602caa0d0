"""The warning for aiding samples a fit leaves out names an option the method takes."""

from __future__ import annotations

import dataclasses

from baselines._oe_aiding_report import aiding_warnings


def test_the_warning_names_what_puts_each_source_in(paper_flight):
    carried = {"gnss": {}, "gnss_position": {}, "ins": {}, "baro": {}}
    flight = dataclasses.replace(paper_flight, metadata={**paper_flight.metadata,
                                                         "aiding": carried})
    oe = aiding_warnings("none", flight)
    assert [w.split("(")[-1] for w in oe] == [
        "aiding = gnss-velocity puts them in)", "aiding = gnss-position puts them in)",
        "aiding = gnss-velocity+ins-attitude puts them in)",
        "aiding = baro-altitude puts them in)"]
    ekf = aiding_warnings("gnss-velocity", flight, "ekf")
    assert [w.split("(")[-1] for w in ekf] == [
        "output-error's aiding = gnss-position puts them in; ekf cannot take them)",
        "aiding = gnss-velocity+ins-attitude puts them in)",
        "output-error's aiding = baro-altitude puts them in; ekf cannot take them)"]
