"""``python -m hybridlog``: the same as the ``hybridlog`` command."""

from hybridlog.launch import main

main()
