"""Online backlash estimation: STSMO perturbation observer, adaptive deadzone law, excitation monitor."""
