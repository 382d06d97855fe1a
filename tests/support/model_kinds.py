"""Small model files of the kinds papers 002–004 need: continuous time, booleans, jumps,
components.  Each is a faithful transcription of the paper's example where one exists."""

# Continuous time, modes written one by one (a tank that drains only while its valve is open).
CONTINUOUS_TANK = """
name = "continuous_tank"
time = "continuous"
dt = 0.01
integration = {method = "euler", step = 0.001}
states = ["h1"]
inputs = ["q"]
outputs = ["y"]

[parameters]
c = 0.5

[modes.open]
dx = ["q - c*sqrt(abs(h1))"]
h = ["h1"]

[modes.closed]
dx = ["q"]
h = ["h1"]

[modes.linear]
dx = ["-2*h1 + 3*q + 1"]
h = ["0.5*h1"]

[modes.matrices]
A = [[-1.0]]
B = [[2.0]]
C = [[1.0]]

[initial]
state = [1.0]
"""

# Paper 003 §IV, eqs. (41)–(46): three tanks, three on/off valves U1..U3, Table 1's values.
# The inflow q is an input; the cross sections are β1 = a·w, β2 = c·w + b·w·H2 and
# β3 = w·sqrt(R² − (R − H3)²).
VALVES_BOOLEAN = """
name = "valves"
reference = "Orani et al. (paper 003), eqs. (41)-(48), Table 1"
time = "continuous"
dt = 0.01
integration = {method = "euler", step = 0.001}
states = ["H1", "H2", "H3"]
inputs = ["q"]
outputs = ["y1", "y2", "y3"]
booleans = ["U1", "U2", "U3"]

[parameters]
C1 = 4.702e-5
C2 = 4.49e-5
C3 = 4.51e-5
a = 0.035
b = 0.348
c = 0.1
w = 0.035
R = 0.365

[dynamics]
dx = [
  "(q - C1*sqrt(H1)*U1)/(a*w)",
  "(C1*sqrt(H1)*U1 - C2*sqrt(H2)*U2)/(c*w + b*w*H2)",
  "(C2*sqrt(H2)*U2 - C3*sqrt(H3)*U3)/(w*sqrt(R**2 - (R - H3)**2))",
]
h = ["H1", "H2", "H3"]

[noise]
measurement = 1e-6

[initial]
state = [0.2, 0.15, 0.1]
mode = "7"
"""

# Paper 004 §6, eqs. (40)–(46): engine and load joined by a clutch (σ = 0 disengaged,
# σ = 1 engaged), τ(ω) = 1/(pω), with the jump maps (45)–(46).  Parameter values are
# plausible choices (the paper gives none).
CLUTCH_JUMPS = """
name = "clutch"
reference = "Germani, Manes, Pepe (paper 004), eqs. (40)-(46)"
time = "continuous"
dt = 0.01
integration = {method = "rk4", step = 0.002}
states = ["m", "omega", "T"]
inputs = ["alpha"]
outputs = ["y"]

[parameters]
p = 0.02
m0 = 0.1
m1 = 0.001
q0 = 0.05
beta_bar = 400.0
gamma = 1e-12
omega_bar = 300.0
JE = 0.2
JL = 0.3
fE = 0.01
fL = 0.02
TE = 5.0
TL = 10.0

[modes.0]
dx = [
  "-p*omega*(m - (m0 + m1*omega)*alpha - q0)",
  "(beta_bar*m*exp(-gamma*(omega - omega_bar)**4) - fE*omega - T)/JE",
  "0",
]
h = ["omega"]

[modes.1]
dx = [
  "-p*omega*(m - (m0 + m1*omega)*alpha - q0)",
  "(beta_bar*m*exp(-gamma*(omega - omega_bar)**4) - (fE + fL)*omega - T)/(JE + JL)",
  "0",
]
h = ["omega"]

[jumps."0->1"]
omega = "JE/(JE + JL)*omega"
T = "(TE + TL)/TE*T"

[jumps."1->0"]
T = "TE/(TE + TL)*T"

[initial]
state = [0.2, 100.0, 5.0]
mode = "0"
"""

# Paper 002 §2.1, eq. (2): the three-component example (Fig. 1).  Only m11, m21 and m31
# are given by the paper; m12 (the input stage off) and m22 (a slower state) are examples
# of further modes so that the transitions have somewhere to go.
THREE_COMPONENTS = """
name = "three_components"
reference = "Hofbaur, Williams (paper 002), eqs. (2)-(3)"
dt = 1.0
states = ["xc1", "xc2", "xc3"]
inputs = ["uc1"]
outputs = ["yc1", "yc2"]
variables = ["wc1"]
commands = ["ud1"]

[noise]
process = [0.01, 0.02, 0.03]
measurement = [0.04, 0.05]

[initial]
state = [0.0, 0.0, 0.0]
covariance = 1.0

[components.A1]
unknown = 0.01
initial = "m11"

[components.A1.modes.m11]
equations = ["uc1 = 5.0*wc1"]

[components.A1.modes.m12]
equations = ["wc1 = 0"]

[[components.A1.transitions]]
from = "m11"
when = {ud1 = 0}
to = {m12 = 0.9}

[[components.A1.transitions]]
from = "*"
to = {m11 = 0.01, m12 = 0.01}

[[components.A1.transitions]]
from = "unknown"
to = {m11 = 0.1}

[components.A2]
unknown = 0.001
initial = {m21 = 0.9, unknown = 0.1}

[components.A2.modes.m21]
equations = ["xc1[k] = 0.8*xc1[k-1] + wc1[k-1]", "yc1 = xc1"]
measurement_noise = {yc1 = 0.5}

[components.A2.modes.m22]
equations = ["xc1[k] = 0.5*xc1[k-1] + wc1[k-1]", "yc1[k] = xc1[k]"]
process_noise = {xc1 = 0.2}

[components.A3]
unknown = 0.0

[components.A3.modes.m31]
equations = [
  "xc2[k] = xc3[k-1] + yc1[k-1]",
  "xc3[k] = 0.4*xc2[k-1] + 0.5*uc1[k-1]",
  "yc2 = 2.0*xc2 + xc3",
]
"""
