"""Direct light: area-light shadow maps (and VSM), the shading of area lights, LTC, punctual lights."""
