// The exported two-axis chipset (chipset.v, from `k37 export-verilog`) for a cocotb
// testbench: the host side of the tristate data bus D as a byte to drive (host_d) and an
// enable (host_drives); every other pin passes through.
`timescale 1ns/1ns
module chipset_tb (
    input  wire        clk, rst,
    input  wire [7:0]  addr,
    input  wire        cs_n, rd_n, wr_n,
    input  wire [7:0]  host_d,
    input  wire        host_drives,
    output wire [7:0]  d,
    input  wire        x_a, x_a_n, x_b, x_b_n, y_a, y_a_n, y_b, y_b_n,
    output wire [15:0] x_dac, y_dac,
    output wire        x_alarm_n, y_alarm_n, irq_interp, irq_alarm
);
    assign d = host_drives ? host_d : 8'bzzzzzzzz;
    chipset dut (
        .clk(clk), .rst(rst), .d(d), .addr(addr), .cs_n(cs_n), .rd_n(rd_n), .wr_n(wr_n),
        .x_a(x_a), .x_a_n(x_a_n), .x_b(x_b), .x_b_n(x_b_n),
        .y_a(y_a), .y_a_n(y_a_n), .y_b(y_b), .y_b_n(y_b_n),
        .x_dac(x_dac), .y_dac(y_dac), .x_alarm_n(x_alarm_n), .y_alarm_n(y_alarm_n),
        .irq_interp(irq_interp), .irq_alarm(irq_alarm));
endmodule
