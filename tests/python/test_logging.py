"""Log messages read the same in every importer (docs/specification.md 7): the message argument is the text
itself with '%' written as '%%' and '#' as '##', and no variable arguments follow it.

A logger that formats the message (fmpy's proxy, like FMI Library and fmusim) turns '%%'
back into '%'; '##' is FMI's escape for a literal '#' (FMI 2.0 section 2.1.5), which
formatting loggers pass on as it is. A logger that prints the message as it comes (a plain
ctypes callback) sees the escaped text, never a bare "%s".
"""

from __future__ import annotations

import pytest

import fmi4_common as fc


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return fc.module_fmu(tmp_path_factory, "fmi4_logging")


def refused_sigma_y(fmu, log):
    md, unzipdir = fmu
    s = fc.new_slave(md, unzipdir, name="logging", log=log)
    try:
        s.setupExperiment(startTime=0.0)
        status, _ = fc.status_of(s.setReal, [fc.PARAMETER_VR["sigmaY"]], [-0.25])
        assert status == fc.FMI2_ERROR
    finally:
        fc.close(s)


def test_a_logger_that_does_not_format_reads_the_whole_message(fmu):
    log = fc.LogCapture(formatting=False)
    refused_sigma_y(fmu, log)
    errors = log.errors()
    assert errors, log.text()
    message = errors[0]
    assert "%s" not in message
    assert "sigmaY" in message and "-0.25" in message, message
    assert message.startswith("fmi2SetReal: ") and "sigmaY = -0.25" in message, message


def category_message(fmu, log, category):
    """The error fmi2SetDebugLogging logs for an unknown category; it quotes the name."""
    md, unzipdir = fmu
    s = fc.new_slave(md, unzipdir, name="logging", log=log)
    try:
        status, _ = fc.status_of(s.setDebugLogging, True, [category])
        assert status == fc.FMI2_ERROR
    finally:
        fc.close(s)
    errors = log.errors()
    assert errors, log.text()
    return errors[0]


CATEGORY = "100% #1 %s %d ##"


def test_percent_and_hash_arrive_intact_through_a_formatting_logger(fmu):
    message = category_message(fmu, fc.LogCapture(formatting=True), CATEGORY)
    # '%%' comes back as '%' and no '%s' or '%d' read a missing argument; '##' is FMI's
    # escaped '#' and is passed on as such by a formatting logger.
    assert f"'{CATEGORY.replace('#', '##')}'" in message, message


def test_percent_and_hash_arrive_escaped_through_a_plain_logger(fmu):
    message = category_message(fmu, fc.LogCapture(formatting=False), CATEGORY)
    assert f"'{CATEGORY.replace('%', '%%').replace('#', '##')}'" in message, message


def test_log_all_gives_each_call_with_its_arguments(fmu):
    """With logging on, the logAll category traces every call that succeeded with its
    arguments: value references and values (those a get returned, too) and times."""
    md, unzipdir = fmu
    log = fc.LogCapture(formatting=True)
    s = fc.new_slave(md, unzipdir, name="trace", log=log, logging_on=True)
    try:
        s.setupExperiment(startTime=0.5)
        s.setReal([fc.PARAMETER_VR["sigmaY"]], [0.75])
        s.enterInitializationMode()
        s.exitInitializationMode()
        s.setReal([fc.INPUT_VR["vx"], fc.INPUT_VR["vy"]], [12.5, -0.25])
        s.doStep(currentCommunicationPoint=0.5, communicationStepSize=0.002)
        fy = s.getReal([fc.OUTPUT_VR["Fy"]])[0]
        model = s.getInteger([fc.MODEL_VR])[0]
    finally:
        fc.close(s)
    traced = [m for (status, category, m) in log.messages if category == "logAll"]
    text = "\n".join(traced)

    def line(prefix):
        found = [m for m in traced if m.startswith(prefix)]
        assert found, f"no logAll message starting {prefix!r}; got:\n{text}"
        return found

    assert any("startTime = 0.5" in m for m in line("fmi2SetupExperiment("))
    assert any(f"vr = [{fc.PARAMETER_VR['sigmaY']}]" in m and "value = [0.75]" in m for m in line("fmi2SetReal("))
    assert any(f"vr = [{fc.INPUT_VR['vx']}, {fc.INPUT_VR['vy']}]" in m and "value = [12.5, -0.25]" in m
               for m in line("fmi2SetReal("))
    assert any("currentCommunicationPoint = 0.5" in m and "communicationStepSize = 0.002" in m
               for m in line("fmi2DoStep("))
    assert any(f"vr = [{fc.OUTPUT_VR['Fy']}]" in m and f"value -> [{fy!r}]" in m for m in line("fmi2GetReal("))
    assert any(f"value -> [{model}]" in m for m in line("fmi2GetInteger("))
    assert line("fmi2ExitInitializationMode(")
