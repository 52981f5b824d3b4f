"""A simulated board behind a socket: the simulated machine with the host bridge's protocol
(``k37 serve``)."""
