"""World assembly: one module per world kind (slider, arm) and the controller registry.

A world module builds the plant, its models and extras, the start pose and the safety
monitor; `controllers.add_controller` is the only place that dispatches on a controller's
config type."""
