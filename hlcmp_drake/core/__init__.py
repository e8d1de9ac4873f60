"""Pure numpy: the paper's equations, one function each, and the metrics of its figures.

Nothing in this folder imports pydrake, so every law can be tested and used without
building a diagram."""
