"""The plant as CasADi expressions and the C code generated from them (needs the ``fmi`` extra)."""

__all__: list[str] = []
