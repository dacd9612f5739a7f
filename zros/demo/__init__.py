"""The rosR tutorial behind ``zros demo``: a simulated Sharp GP2D120 sensor, its bag, the
tutorial's node (log, filter, fit, publish ``sensor_msgs/Range``), its figures and its report.

* :mod:`zros.demo.sensor`: the sensor model and the custom ``rosR_demos/msg/Linearization``
  type (its ``.msg`` file ships in this package);
* :mod:`zros.demo.tutorial_bag`: the bag, made once and deterministically;
* :mod:`zros.demo.analysis`: the tutorial's node;
* :mod:`zros.demo.figures`: the three figures (matplotlib, Agg unless in a window);
* :mod:`zros.demo.run`: all of it on a router inside the process, and the report.

The examples (``examples/sharp_sensor.py``, ``examples/rosr_demo*.py``) use the same sensor.
"""
