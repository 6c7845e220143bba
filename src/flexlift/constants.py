"""Physical defaults, in one place. Every value is SI; the unit is in the comment.

Scenario files may override the environmental ones (see ``scenario.Environment``); library
functions take them as explicit parameters whose defaults come from here.
"""

G = 9.81  # gravitational acceleration [m/s^2]
RHO_SEAWATER = 1025.0  # density of seawater [kg/m^3]
RHO_STEEL = 7850.0  # density of steel [kg/m^3]
P_ATM = 101_325.0  # atmospheric pressure at the surface [Pa]
T_SEA = 283.15  # sea temperature, gas assumed isothermal at it [K]
R_GAS = 8.314462618  # universal gas constant [J/(mol K)]

TONNE = 1000.0  # mass of one tonne [kg]
BAR = 1.0e5  # one bar [Pa]
