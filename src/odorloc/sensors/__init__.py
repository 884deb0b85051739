"""Sensors: gas concentration, particle-encounter counter, PID encounter counts, anemometer, and
signal pre-processing."""

from __future__ import annotations

from odorloc.sensors.anemometer import Anemometer, AnemometerParams
from odorloc.sensors.encounter import EncounterSensor, EncounterSensorParams
from odorloc.sensors.gas import ConcentrationSensor, ConcentrationSensorParams, GasReading
from odorloc.sensors.pid import PIDCountParams, PIDCountSensor, hits_from_concentration
from odorloc.sensors.preprocessing import (
    OnlinePreprocessor,
    PreprocessedSample,
    PreprocessedSignal,
    PreprocessorParams,
    SignalPreprocessor,
    align_delay,
    average_wind,
    delay_steps,
    moving_baseline,
    preprocess,
    relative_concentration,
    signal_intensity,
    wind_from_polar,
)

__all__ = [
    "Anemometer",
    "AnemometerParams",
    "ConcentrationSensor",
    "ConcentrationSensorParams",
    "EncounterSensor",
    "EncounterSensorParams",
    "GasReading",
    "OnlinePreprocessor",
    "PIDCountParams",
    "PIDCountSensor",
    "PreprocessedSample",
    "PreprocessedSignal",
    "PreprocessorParams",
    "SignalPreprocessor",
    "align_delay",
    "average_wind",
    "delay_steps",
    "hits_from_concentration",
    "moving_baseline",
    "preprocess",
    "relative_concentration",
    "signal_intensity",
    "wind_from_polar",
]
