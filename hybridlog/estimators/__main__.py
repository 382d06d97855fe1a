"""``python -m hybridlog.estimators``: print ``docs/estimators.md`` from the registry."""

from hybridlog.estimators.registry import reference_markdown

print(reference_markdown(), end="")
