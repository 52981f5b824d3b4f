"""The reference models of the K3701's datapaths in plain Python, one module per datapath."""
