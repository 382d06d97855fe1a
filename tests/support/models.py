"""Small model files used across the tests."""

LINEAR_TWO_MODE = """
name = "linear_two_mode"
dt = 0.1
states = ["p", "v"]
inputs = ["a"]
outputs = ["y1", "y2"]
default_estimator = "imm"

[modes.slow]
A = [[1.0, 0.1], [0.0, 0.95]]
B = [[0.005], [0.1]]
C = [[1.0, 0.0], [0.0, 1.0]]

[modes.fast]
A = [[1.0, 0.1], [-0.3, 0.7]]
B = [[0.0], [0.2]]
C = [[1.0, 0.0], [0.5, 2.0]]
process_noise = [[0.02, 0.005], [0.005, 0.03]]

[noise]
process = [0.01, 0.02]
measurement = [[0.05, 0.01], [0.01, 0.08]]

[initial]
state = [0.5, -0.2]
covariance = [[1.0, 0.1], [0.1, 2.0]]
mode_probabilities = [0.6, 0.4]

[transitions]
matrix = [[0.97, 0.03], [0.05, 0.95]]

[simulation]
state = [0.0, 0.0]
schedule = "slow:120,fast:80,slow:150,fast:150"

[simulation.inputs]
a = "sin(0.7*t) + 0.5*cos(0.13*t)"
"""

PENDULUM_ONE_MODE = """
name = "pendulum"
dt = 0.05
states = ["theta", "omega"]
inputs = ["torque"]
outputs = ["y_sin", "y_speed"]

[parameters]
g = 9.81
l = 1.3
c = 0.2

[modes.only]
f = ["theta + 0.05*omega", "omega - 0.05*(g/l)*sin(theta) - 0.05*c*omega + 0.05*torque"]
h = ["sin(theta)", "omega + 0.1*theta**2"]

[noise]
process = [1e-4, 4e-4]
measurement = [0.01, 0.02]

[initial]
state = [0.3, 0.0]
covariance = 0.5

[simulation]
state = [1.0, 0.5]

[simulation.inputs]
torque = "0.3*sin(0.5*t)"
"""


POLE = """
name = "pole"
dt = 1
states = ["x"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
f = ["x / u"]
h = ["x"]
[modes.b]
f = ["x / u"]
h = ["x"]
[noise]
process = 0.1
measurement = 0.1
[initial]
state = [2.0]
"""
"""A model whose prediction is infinite where the input is 0: a filter diverges there."""
