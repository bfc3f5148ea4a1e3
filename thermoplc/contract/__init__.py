"""The contract between the generator and the verifier: the names a block gives the model's
values, so that the verifier can read them back without asking the generator.

It sits above the models (it reads their coefficients and settings) and below the generator and
the verifier (both read it); neither of those two imports the other.
"""
