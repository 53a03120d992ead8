"""The studies: one module per paper figure or question. Each computes tables from parameters and draws
figures from tables; the report discovers them."""
