"""slideplan: pre-grasp sliding planning of thin objects (Hang, Morgan, Dollar, RA-L 2019)."""
