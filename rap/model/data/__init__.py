"""What the network reads: dataset rows as batches, the extra input channels and geometric descriptors made from each operation's exact geometry. No ray."""
