"""Running things: simulate a built diagram, run a scenario's controllers, learn and
reproduce over trials, measure where the time goes."""
