// The exported two-axis K3701 (k3701.v, from `k37 export-verilog`) for a cocotb testbench:
// the host side of the tristate data bus D as a byte to drive (host_d) and an enable
// (host_drives); every other pin passes through.
`timescale 1ns/1ns
module k3701_tb (
    input  wire        clk, rst,
    input  wire [4:0]  addr,
    input  wire        cs_n, rd_n, wr_n,
    input  wire [7:0]  host_d,
    input  wire        host_drives,
    output wire [7:0]  d,
    input  wire        fp,
    output wire        x_pos, x_neg, y_pos, y_neg, busy, irq, error, overrun
);
    assign d = host_drives ? host_d : 8'bzzzzzzzz;
    k3701 dut (
        .clk(clk), .rst(rst), .d(d), .addr(addr), .cs_n(cs_n), .rd_n(rd_n), .wr_n(wr_n),
        .fp(fp), .x_pos(x_pos), .x_neg(x_neg), .y_pos(y_pos), .y_neg(y_neg), .busy(busy),
        .irq(irq), .error(error), .overrun(overrun));
endmodule
