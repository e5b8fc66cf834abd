"""The sensor model: ECM equations, coupling k(x), sensor description, named model parts."""
