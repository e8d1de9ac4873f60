"""Drake LeafSystems: references, controllers and the task-space plumbing around the plant."""
