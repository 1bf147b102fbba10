//! HCI 4D Light Field Benchmark metrics: BadPix, MSE×100, Q25.
