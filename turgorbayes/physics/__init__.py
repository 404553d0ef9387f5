"""The physics of one cell, in closed form or through the FE table (docs/physics.md).

* :mod:`~.parameters`: the model's quantities, their units and the paper's values;
* :mod:`~.bulge`: the bulge's pressure from its indentation (the membrane law);
* :mod:`~.wall`: the wall's radius and tension under pressure (the stiffening wall law);
* :mod:`~.outer_membrane`: the outer membrane's share of the load;
* :mod:`~.forward`: a cell's radius and stiffness from the wall law and the FE stiffness
  table (:mod:`turgorbayes.surrogate`, the one layer below this).

Old paths (``turgorbayes.bulge``, ``turgorbayes.forward``, ...) work with a
``DeprecationWarning`` until 0.4.0.
"""
