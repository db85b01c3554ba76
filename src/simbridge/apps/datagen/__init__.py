"""The datagen demo's scene (scene.yaml): the pick-and-place table as a randomised
perception dataset (`simbridge demo datagen`, `simbridge datagen pick-and-place`)."""

__all__: list[str] = []
