"""Error models through calibration points and the correction tables made from them.

- :mod:`.rbf`: Gaussian RBF network on the circle (seed 001 eqs. 5-7);
  :mod:`.fourier`: trigonometric fit; :mod:`.curve_model`: a model as a stream and back.
- :mod:`.rom`: the model evaluated at every address of the code, quantised to counts;
  :mod:`.romformats`: the table written and read back for FPGAs and motion controllers.
"""
