"""The benchmark's task families, one module each; importing this package registers every builder
(:data:`tacreasoner.tasks.building.TASK_BUILDERS`)."""

from tacreasoner.tasks.families import attributes, comparisons, contact, naming, real_fake, suitability

__all__ = ["attributes", "comparisons", "contact", "naming", "real_fake", "suitability"]
