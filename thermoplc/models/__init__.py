"""The model kinds, the model file and the float32 references every block is proven against."""
