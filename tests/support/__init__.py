"""What the tests share: real files of other tools, model texts, reference implementations."""
