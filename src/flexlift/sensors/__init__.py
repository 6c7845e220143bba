"""The lift's sensors: the scenario's ``sensors:`` section as sensors, the sensor log (its
format, a streaming reader that counts every bad line, an appending writer), the sensor model
(rates, noise, latency, dropouts) and the true values from the compiled loop's records
(docs/reference/sensor-log.md)."""

from flexlift.sensors.config import HULL, Sensor, known_names, sensor_name, sensors_of, split_name
from flexlift.sensors.log import LogReader, LogReport, LogWriter, Reading
from flexlift.sensors.model import SensorModel
from flexlift.sensors.tap import SensorTap, run_with_log

__all__ = ["HULL", "LogReader", "LogReport", "LogWriter", "Reading", "Sensor", "SensorModel",
           "SensorTap", "known_names", "run_with_log", "sensor_name", "sensors_of", "split_name"]
