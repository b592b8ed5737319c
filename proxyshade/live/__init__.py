"""The live editing page: ``proxyshade edit`` (docs/editing.md)."""
