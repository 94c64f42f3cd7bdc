"""Server-side processing: clinical calculators and other pure computations on records."""
